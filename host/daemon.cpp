#include "host/daemon.h"

#include <unistd.h>

#include <cstdio>

namespace dca {

namespace {
ChannelOptions channel_options(const DaemonOptions& o) {
  ChannelOptions c{o.key};
  c.handshake_timeout = o.handshake_timeout;
  return c;
}
}  // namespace

Daemon::Daemon(boost::asio::io_context& io, DaemonOptions options)
    : io_(io),
      options_(std::move(options)),
      exec_(io, options_.allow),
      names_(io, options_.host, options_.peers, channel_options(options_)) {}

Daemon::~Daemon() { stop(); }

bool Daemon::start(std::string* error) {
  if (options_.key.empty()) {
    if (error != nullptr) *error = "no cluster key: the daemon refuses to start without one";
    return false;
  }
  if (options_.state_dir.empty()) {
    config_off_ = "no configuration repository on host " + options_.host + " (its daemon runs without a state directory)";
  } else {
    ConfigServiceOptions co;
    co.host = options_.host;
    co.state_dir = options_.state_dir;
    co.peers = options_.peers;
    co.peer_options = channel_options(options_);
    co.sync_interval = options_.config_sync_interval;
    config_ = std::make_unique<ConfigService>(io_, co);
    std::string why;
    const auto r = config_->start(&why);
    if (r != ConfigService::StartError::kNone) {
      config_.reset();
      if (r == ConfigService::StartError::kInUse && options_.state_dir_is_default) {
        config_off_ = "no configuration repository on host " + options_.host + ": " + why;
        std::fprintf(stderr, "dca daemon %s: %s\n", options_.host.c_str(), config_off_.c_str());
      } else {
        if (error != nullptr) *error = why;
        return false;
      }
    }
  }
  listener_ = Listener::listen(
      io_, options_.listen, channel_options(options_), [this](Channel::Ptr ch) { accepted(ch); }, error,
      [this](const std::string& why) {
        if (on_refused_) {
          on_refused_(why);
        } else {
          std::fprintf(stderr, "dca daemon %s: %s\n", options_.host.c_str(), why.c_str());
        }
      });
  return listener_ != nullptr;
}

const Address& Daemon::address() const {
  static const Address none;
  return listener_ ? listener_->address() : none;
}

void Daemon::accepted(const Channel::Ptr& ch) {
  if (stopped_) {
    ch->close("the daemon is stopping", true);
    return;
  }
  channels_.insert(ch);
  std::weak_ptr<Channel> w = ch;
  ch->on_message([this, w](const wire::Message& m) {
    if (auto c = w.lock()) handle(c, m);
  });
  ch->on_close([this, raw = ch.get(), w](const std::string&) {
    names_.channel_closed(raw);
    if (auto c = w.lock()) channels_.erase(c);
  });
}

void Daemon::handle(const Channel::Ptr& ch, const wire::Message& m) {
  if (m.id == 0 && m.type != "kill") {
    // Only kill may come as an event (fire and forget); say so rather than drop it silently.
    std::fprintf(stderr, "dca daemon %s: ignored event '%s' from %s (requests need an id)\n", options_.host.c_str(),
                 m.type.c_str(), ch->peer().c_str());
    return;
  }
  if (m.type == "spawn") {
    spawn(ch, m);
  } else if (m.type == "kill") {
    const wire::Value& sig = m.payload["signal"];
    const int signo = sig.is_nil() ? SIGTERM : sig.is_int() ? static_cast<int>(sig.as_int()) : signal_number(sig.as_string());
    std::string error;
    if (signo == 0) {
      error = "unknown signal " + sig.str();
    } else if (exec_.kill(static_cast<Executer::ChildId>(m.payload["child"].as_int()), signo, &error)) {
      if (m.id != 0) ch->reply(m);
      return;
    }
    error += " on host " + options_.host;
    if (m.id != 0) {
      ch->reply_error(m, error);
    } else {
      std::fprintf(stderr, "dca daemon %s: kill event from %s: %s\n", options_.host.c_str(), ch->peer().c_str(),
                   error.c_str());
    }
  } else if (names_.handle(ch, m)) {
    // register / unregister / lookup
  } else if (m.type == "ping") {
    ch->reply(m, wire::Value::map()
                    .set("host", options_.host)
                    .set("pid", static_cast<std::int64_t>(::getpid()))
                    .set("clock", options_.sim_clock ? "sim" : "wall"));
  } else if (m.type == "status") {
    wire::Value::Array children, names;
    for (const auto& [id, pid] : exec_.children()) {
      auto it = child_names_.find(id);
      children.push_back(wire::Value::map()
                             .set("child", static_cast<std::int64_t>(id))
                             .set("pid", static_cast<std::int64_t>(pid))
                             .set("name", it == child_names_.end() ? std::string() : it->second));
    }
    for (const auto& n : names_.table().names()) names.emplace_back(n);
    ch->reply(m, wire::Value::map().set("host", options_.host).set("children", children).set("names", names));
  } else if (m.type.rfind("config_", 0) == 0) {
    if (config_) {
      config_->handle(ch, m);
    } else {
      ch->reply_error(m, config_off_);
    }
  } else if (!extra_ || !extra_(ch, m)) {
    ch->reply_error(m, "unknown request '" + m.type + "' (daemon on host " + options_.host + ")");
  }
}

void Daemon::spawn(const Channel::Ptr& ch, const wire::Message& m) {
  std::vector<std::string> argv;
  for (const auto& a : m.payload["argv"].as_array()) {
    if (!a.is_string()) {
      ch->reply_error(m, "spawn: argv must be an array of strings");
      return;
    }
    argv.push_back(a.as_string());
  }
  // A host on simulated time: its nodes take the clock from the world (host/node.h) unless told otherwise.
  if (options_.sim_clock && argv.size() >= 2 && argv[1] == "node") {
    bool has_clock = false;
    for (std::size_t i = 2; i < argv.size() && argv[i] != "--"; ++i) has_clock = has_clock || argv[i] == "--clock";
    if (!has_clock) argv.insert(argv.begin() + 2, {"--clock", "sim"});
  }
  const std::string name = m.payload["name"].as_string();
  std::weak_ptr<Channel> requester = ch;
  std::string error;
  const auto child = exec_.spawn(
      argv,
      [this, requester, name](Executer::ChildId id, const ExitStatus& s) {
        child_names_.erase(id);
        wire::Value ev = wire::Value::map()
                             .set("child", static_cast<std::int64_t>(id))
                             .set("pid", static_cast<std::int64_t>(s.pid))
                             .set("name", name)
                             .set("host", options_.host);
        if (s.exited) {
          ev.set("code", s.code);
        } else {
          ev.set("signal", s.signal_name());
          if (s.core) ev.set("core", true);
        }
        if (auto c = requester.lock(); c && c->is_open()) {
          c->send(wire::Message{"exit", 0, std::move(ev)});
        } else {
          std::fprintf(stderr, "dca daemon %s: child %s (pid %d) ended (%s) after its requester left\n",
                       options_.host.c_str(), name.c_str(), static_cast<int>(s.pid), s.str().c_str());
        }
      },
      &error);
  if (!child) {
    ch->reply_error(m, error + " (daemon on host " + options_.host + ")");
    return;
  }
  child_names_[child->id] = name;
  ch->reply(m, wire::Value::map()
                   .set("child", static_cast<std::int64_t>(child->id))
                   .set("pid", static_cast<std::int64_t>(child->pid))
                   .set("host", options_.host));
}

void Daemon::stop() {
  if (stopped_) return;
  stopped_ = true;
  if (listener_) listener_->close();
  exec_.stop_all(options_.stop_grace);
  names_.stop();
  if (config_) config_->stop();
  auto channels = channels_;
  for (const auto& ch : channels) ch->close("the daemon on host " + options_.host + " stopped", true);
  channels_.clear();
}

}  // namespace dca
