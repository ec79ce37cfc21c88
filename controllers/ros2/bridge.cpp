#include "bridge.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <stdexcept>
#include <tuple>

#include <dca/msgs.h>
#include <dca/msgs_cdr.h>
#include <dca/registry.h>

#include "graph.h"

namespace dca::ros2 {
namespace {

// The types a bridge's ports carry: a slot's port is Pub<short><k> or Sub<short><k>.
using Bridged = std::tuple<msgs::JointState, msgs::TFMessage, msgs::Odometry, msgs::Twist, msgs::PoseStamped,
                           msgs::WrenchStamped, msgs::TransformStamped, msgs::Float64MultiArray>;

template <class F>
void for_each_bridged(F&& f) {
  std::apply([&f](const auto&... m) { (f.template operator()<std::remove_cvref_t<decltype(m)>>(), ...); }, Bridged{});
}

/// "JointState" of "sensor_msgs/msg/JointState".
std::string short_name(std::string_view ros_name) { return std::string(ros_name.substr(ros_name.rfind('/') + 1)); }

std::string port_name(std::string_view ros_name, bool pub, int k) {
  return (pub ? "Pub" : "Sub") + short_name(ros_name) + std::to_string(k);
}

const Param<std::string> kTopics{.name = "topics",
                                 .doc = "the table: 'TOPIC TYPE pub|sub [PROFILE]' rows, ';' between (docs/ros2.md)"};
const Param<std::string> kNode{.name = "node", .doc = "the ROS 2 node's name", .def = "dca_bridge"};
const Param<std::int64_t> kDomain{
    .name = "domain", .doc = "the DDS domain id (ROS_DOMAIN_ID)", .def = 0, .min = 0, .max = 232};
const Param<std::string> kInterface{
    .name = "interface", .doc = "the network interface ('' : Cyclone's choice)", .def = ""};
const Param<std::string> kSecurity{
    .name = "security", .doc = "an SROS2 enclave's directory: DDS Security ('' : none; docs/ros2.md)", .def = ""};
const Param<std::string> kPeers{
    .name = "peers", .doc = "unicast peers' addresses, spaces between ('' : none)", .def = ""};

/// A single-producer single-consumer queue of messages (the DDS thread -> the node's loop), bounded.
template <class M>
class Queue {
 public:
  explicit Queue(std::size_t capacity) : items_(capacity + 1) {}
  bool push(const M& m) {
    const std::size_t t = tail_.load(std::memory_order_relaxed), next = (t + 1) % items_.size();
    if (next == head_.load(std::memory_order_acquire)) return false;
    items_[t] = m;
    tail_.store(next, std::memory_order_release);
    return true;
  }
  bool pop(M& m) {
    const std::size_t h = head_.load(std::memory_order_relaxed);
    if (h == tail_.load(std::memory_order_acquire)) return false;
    m = items_[h];
    head_.store((h + 1) % items_.size(), std::memory_order_release);
    return true;
  }

 private:
  std::vector<M> items_;
  std::atomic<std::size_t> head_{0}, tail_{0};
};

bool valid_node_name(std::string_view s) {
  if (s.empty() || (s[0] >= '0' && s[0] <= '9')) return false;
  for (const char c : s)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

std::vector<std::string> words(std::string_view row) {
  std::vector<std::string> w;
  std::size_t i = 0;
  while (i < row.size()) {
    while (i < row.size() && (row[i] == ' ' || row[i] == '\t' || row[i] == '\n')) ++i;
    std::size_t j = i;
    while (j < row.size() && row[j] != ' ' && row[j] != '\t' && row[j] != '\n') ++j;
    if (j > i) w.emplace_back(row.substr(i, j - i));
    i = j;
  }
  return w;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& t : v) s += (s.empty() ? "" : ", ") + t;
  return s;
}

}  // namespace

/// One row: its port and its DDS endpoint.
class Link {
 public:
  virtual ~Link() = default;
  Endpoint endpoint;
  bool pub = true;
  std::atomic<std::uint64_t> dropped{0}, refused{0};
  /// MainCalc: a pub row publishes its input's new sample; a sub row writes what the DDS thread queued.
  virtual void tick() = 0;
  /// The DDS thread: a sample of a sub row.
  virtual void receive(std::span<const std::byte> cdr) = 0;
  virtual void clear() = 0;
};

namespace {

template <class M>
class PubLink final : public Link {
 public:
  explicit PubLink(In<M> in) : in_(in) {}
  void tick() override {
    if (in_.read(m_) != Read::New) return;
    const std::size_t n = msgs::cdr_encode(m_, buf_);
    if (n == 0 || !write(endpoint, std::span(buf_).first(n))) dropped.fetch_add(1, std::memory_order_relaxed);
  }
  void receive(std::span<const std::byte>) override {}
  void clear() override {}

 private:
  In<M> in_;
  M m_{};
  std::array<std::byte, msgs::cdr_max_size<M>> buf_{};
};

template <class M>
class SubLink final : public Link {
 public:
  SubLink(Out<M> out, std::size_t depth) : out_(out), queue_(depth) {}
  void tick() override {
    while (queue_.pop(m_)) out_.write(m_);
  }
  void receive(std::span<const std::byte> cdr) override {
    if (!msgs::cdr_decode(cdr, in_)) return void(refused.fetch_add(1, std::memory_order_relaxed));
    if (!queue_.push(in_)) dropped.fetch_add(1, std::memory_order_relaxed);
  }
  void clear() override {
    while (queue_.pop(m_)) {
    }
  }

 private:
  Out<M> out_;
  Queue<M> queue_;
  M m_{};   // the node's loop's
  M in_{};  // the DDS thread's
};

}  // namespace

std::vector<std::string> bridged_types() {
  std::vector<std::string> t;
  for_each_bridged([&t]<class M>() { t.emplace_back(M::ros_name); });
  return t;
}

std::vector<Row> parse_table(std::string_view table) {
  std::vector<Row> rows;
  std::size_t at = 0;
  for (int n = 1; at <= table.size(); ++n) {
    const std::size_t end = std::min(table.find(';', at), table.size());
    const std::vector<std::string> w = words(table.substr(at, end - at));
    at = end + 1;
    if (w.empty()) continue;
    const std::string where = "row " + std::to_string(n) + " ('" + w[0] + "')";
    if (w.size() < 3 || w.size() > 4)
      throw std::invalid_argument(where + ": 'TOPIC TYPE pub|sub [PROFILE]', got " + std::to_string(w.size()) +
                                  " words");
    std::string why;
    if (dds_topic(w[0], &why).empty()) throw std::invalid_argument(where + ": " + why);
    const std::vector<std::string> types = bridged_types();
    if (std::find(types.begin(), types.end(), w[1]) == types.end())
      throw std::invalid_argument(where + ": type '" + w[1] + "' is not bridged (bridged: " + joined(types) + ")");
    if (w[2] != "pub" && w[2] != "sub")
      throw std::invalid_argument(where + ": direction '" + w[2] + "' is not pub or sub");
    Row r{.topic = w[0], .type = w[1], .pub = w[2] == "pub", .profile = w.size() == 4 ? w[3] : "", .port = ""};
    if (r.profile.empty()) r.profile = r.topic == "/tf_static" ? "tf_static" : "default";
    if (!qos_profile(r.profile))
      throw std::invalid_argument(where + ": QoS profile '" + r.profile +
                                  "' is not default, sensor_data, tf_static or transient_local");
    int k = 0;
    for (const Row& o : rows) k += o.type == r.type && o.pub == r.pub;
    if (k >= kSlots)
      throw std::invalid_argument(where + ": more than " + std::to_string(kSlots) + " " + w[2] + " rows of " + r.type);
    for (const Row& o : rows)
      if (o.topic == r.topic && o.pub == r.pub) throw std::invalid_argument(where + ": " + r.topic + " twice");
    r.port = port_name(r.type, r.pub, k);
    rows.push_back(std::move(r));
  }
  if (rows.empty()) throw std::invalid_argument("the table names no topic");
  return rows;
}

Manifest Ros2Bridge::Describe() {
  Manifest m{.type = "ros2_bridge",
             .doc = "ROS 2 topics as ports, on Cyclone DDS: a node that ROS 2 sees (docs/ros2.md)",
             .params = {kTopics, kNode, kDomain, kInterface, kPeers, kSecurity, PeriodParam()},
             .ends = Ending::Never()};
  for_each_bridged([&m]<class M>() {
    for (int k = 0; k < kSlots; ++k) {
      m.inputs.push_back(InSpec<M>{.name = port_name(M::ros_name, true, k)});
      m.outputs.push_back(OutSpec<M>{.name = port_name(M::ros_name, false, k)});
    }
  });
  return m;
}

Ros2Bridge::Ros2Bridge(const ControllerContext& ctx) : PeriodicController(ctx), node_(param(kNode)) {
  try {
    rows_ = parse_table(param(kTopics));
  } catch (const std::invalid_argument& e) {
    throw bad_param(std::string("parameter 'topics': ") + e.what());
  }
  if (!valid_node_name(node_))
    throw bad_param("parameter 'node': '" + node_ + "' is not a ROS 2 node name (letters, digits, '_')");
  // an interface's name or address, peers' addresses: they go into Cyclone's XML configuration, so nothing else
  const auto address_like = [](const std::string& text, bool spaces) {
    return std::all_of(text.begin(), text.end(), [spaces](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '.' || c == ':' || c == '-' || c == '_' ||
             c == '[' || c == ']' || (spaces && c == ' ');
    });
  };
  if (!address_like(param(kInterface), false))
    throw bad_param("parameter 'interface': '" + param(kInterface) +
                    "' is not an interface's name or address (letters, digits, '.', ':', '-', '_')");
  if (!address_like(param(kPeers), true))
    throw bad_param("parameter 'peers': '" + param(kPeers) +
                    "' is not addresses between spaces (letters, digits, '.', ':', '-', '_', '[', ']')");
  options_ = {.domain = static_cast<std::uint32_t>(param(kDomain)),
              .interface = param(kInterface),
              .peers = param(kPeers),
              .security = param(kSecurity)};
  for (const Row& r : rows_) {
    for_each_bridged([&]<class M>() {
      if (r.type != M::ros_name) return;
      const int k = r.port.back() - '0';
      if (r.pub) {
        links_.push_back(std::make_unique<PubLink<M>>(port(InSpec<M>{.name = port_name(M::ros_name, true, k)})));
      } else {
        const auto depth = static_cast<std::size_t>(qos_profile(r.profile)->depth);
        links_.push_back(
            std::make_unique<SubLink<M>>(port(OutSpec<M>{.name = port_name(M::ros_name, false, k)}), depth));
      }
      links_.back()->pub = r.pub;
    });
  }
}

Ros2Bridge::~Ros2Bridge() {
  if (thread_.joinable()) {
    stop_ = true;
    waitset_->wake();
    thread_.join();
  }
  waitset_.reset();
  participant_.reset();  // deletes every endpoint with it
}

std::uint64_t Ros2Bridge::dropped() const {
  std::uint64_t n = 0;
  for (const auto& l : links_) n += l->dropped.load();
  return n;
}

std::uint64_t Ros2Bridge::refused() const {
  std::uint64_t n = 0;
  for (const auto& l : links_) n += l->refused.load();
  return n;
}

Endpoint Ros2Bridge::endpoint(std::size_t i) const { return links_.at(i)->endpoint; }

void Ros2Bridge::on_configure() {
  if (!participant_) open();
}

// The participant, every row's endpoint, the graph's writer and the DDS thread: once, at the first configure().
void Ros2Bridge::open() {
  auto p = std::make_unique<Participant>(options_);
  auto ws = std::make_unique<WaitSet>(*p);
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const Row& r = rows_[i];
    for_each_bridged([&]<class M>() {
      if (r.type != M::ros_name) return;
      const std::string topic = dds_topic(r.topic, nullptr);
      const QosProfile q = *qos_profile(r.profile);
      links_[i]->endpoint =
          r.pub ? p->writer(topic, M::dds_name, M::type_hash, q) : p->reader(topic, M::dds_name, M::type_hash, q);
      if (!r.pub) ws->add(links_[i]->endpoint);
    });
  }
  graph_ = p->writer(std::string(kDiscoveryTopic), ParticipantEntitiesInfo::dds_name, "",
                     QosProfile{.reliable = true, .transient_local = true, .depth = 1});
  participant_ = std::move(p);
  waitset_ = std::move(ws);
  publish_graph();
  thread_ = std::thread([this] { receive_loop(); });
}

void Ros2Bridge::publish_graph() {
  auto info = std::make_unique<ParticipantEntitiesInfo>();
  info->gid.data = participant_->gid();
  NodeEntitiesInfo node;
  node.node_namespace.assign("/");
  node.node_name.assign(node_);
  for (const auto& l : links_) {
    GidMsg g;
    g.data = l->endpoint.gid;
    (l->pub ? node.writer_gid_seq : node.reader_gid_seq).push_back(g);
  }
  info->node_entities_info_seq.push_back(node);
  std::vector<std::byte> buf(msgs::cdr_size(*info));
  msgs::cdr_encode(*info, buf);
  if (!write(graph_, buf)) throw std::runtime_error("DDS: cannot publish " + std::string(kDiscoveryTopic));
}

void Ros2Bridge::receive_loop() {
  while (!stop_.load()) {
    waitset_->wait(1000);
    for (const auto& l : links_)
      if (!l->pub) take(l->endpoint, [&l](std::span<const std::byte> cdr) { l->receive(cdr); });
  }
}

void Ros2Bridge::on_start(const msgpack::object&) {
  for (const auto& l : links_) l->clear();  // a run starts from what arrives after it started
}

void Ros2Bridge::MainCalc() {
  for (const auto& l : links_) l->tick();
}

DCA_REGISTER_CONTROLLER(Ros2Bridge);

}  // namespace dca::ros2
