#include "host/daemon.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "host/node.h"
#include "host/systemd.h"

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
      leases_(io, exec_, options_.host),
      names_(io, options_.host, options_.peers, channel_options(options_)) {
  leases_.on_fenced = [this](Executer::ChildId id, const std::string& why) { reasons_.try_emplace(id, why); };
}

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
        systemd::log(systemd::Priority::warning, "dca daemon %s: %s", options_.host.c_str(), config_off_.c_str());
      } else {
        if (error != nullptr) *error = why;
        return false;
      }
    }
  }
  // the package store of rolling upgrades lives beside the replica, and only with it
  packages_ = std::make_unique<PackageStore>(options_.host, config_ ? options_.state_dir + "/packages" : "",
                                             "no package store on host " + options_.host +
                                                 " (its daemon runs without a state directory)");
  packages_->start();
  listener_ = Listener::listen(
      io_, options_.listen, channel_options(options_), [this](Channel::Ptr ch) { accepted(ch); }, error,
      [this](const std::string& why) {
        if (on_refused_) {
          on_refused_(why);
        } else {
          systemd::log(systemd::Priority::warning, "dca daemon %s: %s", options_.host.c_str(), why.c_str());
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
    leases_.closed(raw);
    std::vector<Executer::ChildId> held;
    for (const auto& [id, sh] : shared_)
      if (sh.holders.count(raw)) held.push_back(id);
    for (auto id : held) release(raw, id);
    if (auto c = w.lock()) channels_.erase(c);
  });
}

void Daemon::handle(const Channel::Ptr& ch, const wire::Message& m) {
  if (m.id == 0 && m.type != "kill") {
    // Only kill may come as an event (fire and forget); say so rather than drop it silently.
    systemd::log(systemd::Priority::warning, "dca daemon %s: ignored event '%s' from %s (requests need an id)",
                 options_.host.c_str(), m.type.c_str(), ch->peer().c_str());
    return;
  }
  if (m.type == "spawn") {
    spawn(ch, m);
  } else if (m.type == "release") {
    const auto id = static_cast<Executer::ChildId>(m.payload["child"].as_int());
    if (!shared_.count(id)) return void(ch->reply_error(m, "release: no shared child " + std::to_string(id) +
                                                              " on host " + options_.host));
    release(ch.get(), id);
    ch->reply(m);
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
      systemd::log(systemd::Priority::warning, "dca daemon %s: kill event from %s: %s", options_.host.c_str(),
                   ch->peer().c_str(), error.c_str());
    }
  } else if (m.type == "failed") {
    failed(ch, m);
  } else if (names_.handle(ch, m)) {
    // register / unregister / lookup
  } else if (m.type == "ping") {
    leases_.renew(ch.get());
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
  } else if (packages_ && packages_->handle(ch, m)) {
    // package_install / package_rollback / package_status
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
  const bool shared = m.payload["shared"].is_bool() && m.payload["shared"].as_bool();
  double fence = 0, kill_after = 0;
  if (!fence_of(ch, m, &fence, &kill_after)) return;
  if (shared && join(ch, m, name)) {
    if (fence > 0) leases_.grant(ch.get(), ch->peer(), shared_by_name_.at(name), name, fence, kill_after);
    return;
  }
  std::weak_ptr<Channel> requester = ch;
  std::string error;
  const auto child = exec_.spawn(
      argv,
      [this, requester, name](Executer::ChildId id, const ExitStatus& s) { exited(id, name, requester, s); },
      &error, [this](Executer::ChildId id, const std::string& line) { output(id, line); });
  if (!child) {
    ch->reply_error(m, error + " (daemon on host " + options_.host + ")");
    return;
  }
  child_names_[child->id] = name;
  if (fence > 0) leases_.grant(ch.get(), ch->peer(), child->id, name, fence, kill_after);
  outputs_[child->id] = Output{requester, name, static_cast<int>(child->pid), kOutputBurst, std::chrono::steady_clock::now(), 0};
  if (shared) {
    auto& sh = shared_[child->id];
    sh.name = name;
    sh.pid = static_cast<int>(child->pid);
    sh.holders[ch.get()] = ch;
    shared_by_name_[name] = child->id;
  }
  ch->reply(m, wire::Value::map()
                   .set("child", static_cast<std::int64_t>(child->id))
                   .set("pid", static_cast<std::int64_t>(child->pid))
                   .set("host", options_.host)
                   .set("joined", false));
}

// A spawn's fencing (host/fence.h): *fence = 0 without one. False, having answered the error, when it is bad.
bool Daemon::fence_of(const Channel::Ptr& ch, const wire::Message& m, double* fence, double* kill_after) {
  const wire::Value& f = m.payload["fence"];
  if (f.is_nil()) return true;
  const wire::Value& k = m.payload["kill_after"];
  *fence = f.as_float(-1);
  *kill_after = k.is_nil() ? *fence / 4 : k.as_float(-1);
  const auto ok = [](double s) { return s > 0 && s <= 3600; };  // (NaN fails both)
  if (f.is_number() && ok(*fence) && (k.is_nil() || k.is_number()) && ok(*kill_after)) return true;
  ch->reply_error(m, "spawn: fence and kill_after must be seconds above 0 and at most 3600, not " + f.str() + " and " +
                         k.str() + " (daemon on host " + options_.host + ")");
  return false;
}

// A child that failed before it was ready says why (host/node.h): the reason, at most 4 KiB, goes to its log
// line here and with its exit event.
void Daemon::failed(const Channel::Ptr& ch, const wire::Message& m) {
  const std::int64_t pid = m.payload["pid"].as_int();
  for (const auto& [id, p] : exec_.children()) {
    if (p != pid) continue;
    std::string reason = m.payload["reason"].is_string() ? m.payload["reason"].as_string() : "(no reason given)";
    if (reason.size() > 4096) reason = reason.substr(0, 4096) + "...";
    systemd::log(systemd::Priority::err, "dca daemon %s: %s (pid %d) failed to start: %s", options_.host.c_str(),
                 child_names_[id].c_str(), static_cast<int>(pid), reason.c_str());
    reasons_[id] = std::move(reason);
    return void(ch->reply(m));
  }
  ch->reply_error(m, "failed: no child with pid " + std::to_string(pid) + " on host " + options_.host);
}

// Where child `id`'s lines go: its requester, or a shared child's first open holder (nullptr: nobody).
Channel::Ptr Daemon::output_channel(Executer::ChildId id) {
  if (auto sh = shared_.find(id); sh != shared_.end()) {
    for (const auto& [raw, w] : sh->second.holders)
      if (auto c = w.lock(); c && c->is_open()) return c;
    return nullptr;
  }
  auto it = outputs_.find(id);
  auto c = it == outputs_.end() ? nullptr : it->second.to.lock();
  return c && c->is_open() ? c : nullptr;
}

// The count of child `id`'s lines left out since the last one sent, if any, told to `to`.
void Daemon::tell_dropped(Executer::ChildId id, const Channel::Ptr& to) {
  auto it = outputs_.find(id);
  if (it == outputs_.end() || it->second.dropped == 0 || !to) return;
  Output& o = it->second;
  to->send({"output", 0, wire::Value::map()
                             .set("child", static_cast<std::int64_t>(id))
                             .set("pid", static_cast<std::int64_t>(o.pid))
                             .set("name", o.name)
                             .set("host", options_.host)
                             .set("dropped", static_cast<std::int64_t>(o.dropped))});
  o.dropped = 0;
}

// A line child `id` wrote to its stderr: into this daemon's log as it is, and to its requester within the
// budget (header comment); beyond it, counted.
void Daemon::output(Executer::ChildId id, const std::string& line) {
  systemd::log_line(systemd::Priority::info, line);
  auto it = outputs_.find(id);
  if (it == outputs_.end()) return;
  Output& o = it->second;
  const auto now = std::chrono::steady_clock::now();
  o.tokens = std::min(kOutputBurst, o.tokens + kOutputRate * std::chrono::duration<double>(now - o.at).count());
  o.at = now;
  const auto to = output_channel(id);
  // (once lines were left out, half the burst comes back first: a count, then a run of lines, not one each)
  if (!to || o.tokens < (o.dropped > 0 ? kOutputBurst / 2 : 1) || to->queued_bytes() > kOutputBacklog) {
    ++o.dropped;
    return;
  }
  o.tokens -= 1;
  tell_dropped(id, to);
  to->send({"output", 0, wire::Value::map()
                             .set("child", static_cast<std::int64_t>(id))
                             .set("pid", static_cast<std::int64_t>(o.pid))
                             .set("name", o.name)
                             .set("host", options_.host)
                             .set("line", line)});
}

// A shared spawn of a name whose child runs and is held: the requester holds it too. False when there is none.
bool Daemon::join(const Channel::Ptr& ch, const wire::Message& m, const std::string& name) {
  auto it = shared_by_name_.find(name);
  if (it == shared_by_name_.end()) return false;
  auto& sh = shared_.at(it->second);
  sh.holders[ch.get()] = ch;
  ch->reply(m, wire::Value::map()
                   .set("child", static_cast<std::int64_t>(it->second))
                   .set("pid", static_cast<std::int64_t>(sh.pid))
                   .set("host", options_.host)
                   .set("joined", true));
  return true;
}

// `holder` lets go of shared child `id`; the last one to let go ends it (SIGTERM: its orderly stop).
void Daemon::release(Channel* holder, Executer::ChildId id) {
  auto it = shared_.find(id);
  if (it == shared_.end() || !it->second.holders.erase(holder) || !it->second.holders.empty()) return;
  auto by = shared_by_name_.find(it->second.name);
  if (by != shared_by_name_.end() && by->second == id) shared_by_name_.erase(by);
  std::string error;
  if (!exec_.kill(id, SIGTERM, &error))
    systemd::log(systemd::Priority::warning, "dca daemon %s: ending shared child %s: %s", options_.host.c_str(),
                 it->second.name.c_str(), error.c_str());
}

// A child ended: the exit event goes to its requester, or to every holder of a shared child.
void Daemon::exited(Executer::ChildId id, const std::string& name, const std::weak_ptr<Channel>& requester,
                    const ExitStatus& s) {
  child_names_.erase(id);
  leases_.exited(id);
  wire::Value ev = wire::Value::map()
                       .set("child", static_cast<std::int64_t>(id))
                       .set("pid", static_cast<std::int64_t>(s.pid))
                       .set("name", name)
                       .set("host", options_.host);
  if (auto r = reasons_.find(id); r != reasons_.end()) {
    ev.set("reason", r->second);
    reasons_.erase(r);
  }
  if (s.exited) {
    ev.set("code", s.code);
  } else {
    ev.set("signal", s.signal_name());
    if (s.core) ev.set("core", true);
  }
  if (shared_.count(id)) {
    // a shared node's crash note (host/node.h): the leaf whose code ran, at most 1 KiB, a hint only
    const std::string note = crash_note_path(static_cast<int>(s.pid));
    if (!s.exited) {
      std::ifstream in(note, std::ios::binary);
      std::string who(1024, '\0');
      in.read(who.data(), static_cast<std::streamsize>(who.size()));
      who.resize(static_cast<std::size_t>(in.gcount()));
      who.resize(std::min(who.find('\0'), who.size()));
      if (!who.empty()) ev.set("culprit", who);
    }
    std::error_code ec;
    std::filesystem::remove(note, ec);
  }
  std::vector<Channel::Ptr> to;
  bool released = false;  // a shared child nobody holds any more: its end was asked for
  if (auto sh = shared_.find(id); sh != shared_.end()) {
    released = sh->second.holders.empty();
    for (const auto& [raw, w] : sh->second.holders)
      if (auto c = w.lock()) to.push_back(c);
    if (auto by = shared_by_name_.find(name); by != shared_by_name_.end() && by->second == id) shared_by_name_.erase(by);
    shared_.erase(sh);
  } else if (auto c = requester.lock()) {
    to.push_back(c);
  }
  if (auto o = outputs_.find(id); o != outputs_.end()) {
    if (!to.empty()) tell_dropped(id, to.front());
    outputs_.erase(o);
  }
  bool told = false;
  for (const auto& c : to)
    if (c->is_open()) {
      c->send(wire::Message{"exit", 0, ev});
      told = true;
    }
  if (!told && !released)
    systemd::log(systemd::Priority::notice, "dca daemon %s: child %s (pid %d) ended (%s) after its requester left",
                 options_.host.c_str(), name.c_str(), static_cast<int>(s.pid), s.str().c_str());
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
