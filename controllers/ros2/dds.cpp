// Cyclone DDS for the package ros2 (dds.h; docs/ros2.md). The raw sertype: a sample is its CDR bytes, kept as
// they came (from the network) or as the bridge encoded them (dca/msgs_cdr.h). ROS 2's types have no keys, so
// every key operation is trivial.
#include "dds.h"

#include <dlfcn.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <new>
#include <stdexcept>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>
#include <dds/ddsi/q_radmin.h>

namespace dca::ros2 {
namespace {

// ---- the raw sertype ----

// The sample's bytes, then zeros to a multiple of 4 (what to_ser_ref may be asked for).
struct RawSerdata : ddsi_serdata {
  std::vector<unsigned char> bytes;
  std::size_t size = 0;
  void resize(std::size_t n) {
    size = n;
    bytes.resize((n + 3) / 4 * 4);
  }
};

RawSerdata* make_serdata(const ddsi_sertype* type, ddsi_serdata_kind kind, std::size_t size) {
  auto* d = new RawSerdata();
  ddsi_serdata_init(d, type, kind);
  d->hash = type->serdata_basehash;  // no key: every sample is the one instance
  d->resize(kind == SDK_DATA ? size : 0);
  return d;
}

const RawSerdata* raw(const ddsi_serdata* d) { return static_cast<const RawSerdata*>(d); }

uint32_t sd_size(const ddsi_serdata* d) { return static_cast<uint32_t>(raw(d)->size); }
void sd_free(ddsi_serdata* d) { delete static_cast<RawSerdata*>(d); }

ddsi_serdata* sd_from_ser(const ddsi_sertype* type, ddsi_serdata_kind kind, const nn_rdata* frag, size_t size) {
  RawSerdata* d = make_serdata(type, kind, size);
  if (kind != SDK_DATA) return d;
  uint32_t off = 0;
  for (; frag != nullptr; frag = frag->nextfrag) {
    if (frag->maxp1 <= off) continue;  // fragments may overlap: copy only what is new
    if (frag->maxp1 > size || frag->min > off) break;
    const unsigned char* payload = NN_RMSG_PAYLOADOFF(frag->rmsg, NN_RDATA_PAYLOAD_OFF(frag));
    std::memcpy(d->bytes.data() + off, payload + (off - frag->min), frag->maxp1 - off);
    off = frag->maxp1;
  }
  d->resize(off);
  return d;
}

ddsi_serdata* sd_from_ser_iov(const ddsi_sertype* type, ddsi_serdata_kind kind, ddsrt_msg_iovlen_t niov,
                              const ddsrt_iovec_t* iov, size_t size) {
  RawSerdata* d = make_serdata(type, kind, size);
  if (kind != SDK_DATA) return d;
  std::size_t off = 0;
  for (ddsrt_msg_iovlen_t i = 0; i < niov && off < size; ++i) {
    const std::size_t n = std::min<std::size_t>(iov[i].iov_len, size - off);
    std::memcpy(d->bytes.data() + off, iov[i].iov_base, n);
    off += n;
  }
  d->resize(off);
  return d;
}

ddsi_serdata* sd_from_keyhash(const ddsi_sertype* type, const ddsi_keyhash*) { return make_serdata(type, SDK_KEY, 0); }

// A typed sample of the raw sertype is a ddsi_sertype_cdr_data_t: its size and malloc'd bytes.
ddsi_serdata* sd_from_sample(const ddsi_sertype* type, ddsi_serdata_kind kind, const void* sample) {
  const auto* s = static_cast<const ddsi_sertype_cdr_data_t*>(sample);
  RawSerdata* d = make_serdata(type, kind, s->sz);
  if (kind == SDK_DATA && s->sz > 0) std::memcpy(d->bytes.data(), s->data, s->sz);
  return d;
}

void sd_to_ser(const ddsi_serdata* d, size_t off, size_t sz, void* buf) {
  const auto& b = raw(d)->bytes;
  const std::size_t n = off < b.size() ? std::min(sz, b.size() - off) : 0;
  if (n > 0) std::memcpy(buf, b.data() + off, n);
  if (n < sz) std::memset(static_cast<unsigned char*>(buf) + n, 0, sz - n);  // the padding to 4 bytes
}

ddsi_serdata* sd_to_ser_ref(const ddsi_serdata* d, size_t off, size_t sz, ddsrt_iovec_t* ref) {
  const auto& b = raw(d)->bytes;  // Cyclone asks for up to the size rounded up to 4: all of b
  off = std::min(off, b.size());
  ref->iov_base = const_cast<unsigned char*>(b.data()) + off;
  ref->iov_len = static_cast<ddsrt_iov_len_t>(std::min(sz, b.size() - off));
  return ddsi_serdata_ref(d);
}

void sd_to_ser_unref(ddsi_serdata* d, const ddsrt_iovec_t*) { ddsi_serdata_unref(d); }

bool sd_to_sample(const ddsi_serdata* d, void* sample, void**, void*) {
  auto* s = static_cast<ddsi_sertype_cdr_data_t*>(sample);
  const RawSerdata* r = raw(d);
  std::free(s->data);
  s->data = static_cast<uint8_t*>(std::malloc(r->size == 0 ? 1 : r->size));
  if (s->data == nullptr) return s->sz = 0, false;
  if (r->size > 0) std::memcpy(s->data, r->bytes.data(), r->size);
  s->sz = static_cast<uint32_t>(r->size);
  return true;
}

ddsi_serdata* sd_to_untyped(const ddsi_serdata* d) {
  RawSerdata* u = make_serdata(d->type, SDK_KEY, 0);
  u->type = nullptr;
  return u;
}

bool sd_untyped_to_sample(const ddsi_sertype*, const ddsi_serdata*, void* sample, void**, void*) {
  auto* s = static_cast<ddsi_sertype_cdr_data_t*>(sample);
  s->sz = 0;
  return true;
}

bool sd_eqkey(const ddsi_serdata*, const ddsi_serdata*) { return true; }

size_t sd_print(const ddsi_sertype*, const ddsi_serdata* d, char* buf, size_t size) {
  const int n = std::snprintf(buf, size, "(%zu bytes of CDR)", raw(d)->size);
  return n < 0 ? 0 : static_cast<size_t>(n);
}

void sd_get_keyhash(const ddsi_serdata*, ddsi_keyhash* buf, bool) { std::memset(buf, 0, sizeof(*buf)); }

const ddsi_serdata_ops kSerdataOps = {
    .eqkey = sd_eqkey,
    .get_size = sd_size,
    .from_ser = sd_from_ser,
    .from_ser_iov = sd_from_ser_iov,
    .from_keyhash = sd_from_keyhash,
    .from_sample = sd_from_sample,
    .to_ser = sd_to_ser,
    .to_ser_ref = sd_to_ser_ref,
    .to_ser_unref = sd_to_ser_unref,
    .to_sample = sd_to_sample,
    .to_untyped = sd_to_untyped,
    .untyped_to_sample = sd_untyped_to_sample,
    .free = sd_free,
    .print = sd_print,
    .get_keyhash = sd_get_keyhash,
#ifdef DDS_HAS_SHM
    .get_sample_size = nullptr,
    .from_iox_buffer = nullptr,
#endif
};

void st_free(ddsi_sertype* t) {
  ddsi_sertype_fini(t);
  delete t;
}
void st_zero_samples(const ddsi_sertype*, void* samples, size_t count) {
  std::memset(samples, 0, count * sizeof(ddsi_sertype_cdr_data_t));
}
void st_realloc_samples(void** ptrs, const ddsi_sertype*, void* old, size_t oldcount, size_t count) {
  const std::size_t size = sizeof(ddsi_sertype_cdr_data_t);
  auto* p = static_cast<char*>(std::realloc(old, count * size));
  if (p != nullptr && count > oldcount) std::memset(p + oldcount * size, 0, (count - oldcount) * size);
  for (size_t i = 0; i < count; ++i) ptrs[i] = p + i * size;
}
void st_free_samples(const ddsi_sertype*, void** ptrs, size_t count, dds_free_op_t op) {
  if (count == 0) return;
  auto* first = static_cast<ddsi_sertype_cdr_data_t*>(ptrs[0]);
  for (size_t i = 0; i < count; ++i) {
    auto* s = static_cast<ddsi_sertype_cdr_data_t*>(ptrs[i]);
    std::free(s->data);
    s->data = nullptr;
  }
  if (op & DDS_FREE_ALL_BIT) std::free(first);
}
bool st_equal(const ddsi_sertype*, const ddsi_sertype*) { return true; }  // the names were compared
uint32_t st_hash(const ddsi_sertype*) { return 0; }

const ddsi_sertype_ops kSertypeOps = {
    .version = ddsi_sertype_v0,
    .arg = nullptr,
    .free = st_free,
    .zero_samples = st_zero_samples,
    .realloc_samples = st_realloc_samples,
    .free_samples = st_free_samples,
    .equal = st_equal,
    .hash = st_hash,
    .type_id = nullptr,
    .type_map = nullptr,
    .type_info = nullptr,
    .derive_sertype = nullptr,
    .get_serialized_size = nullptr,
    .serialize_into = nullptr,
};

ddsi_sertype* raw_sertype(std::string_view type) {
  auto* t = new ddsi_sertype();
  ddsi_sertype_init(t, std::string(type).c_str(), &kSertypeOps, &kSerdataOps, true);
  return t;
}

// ---- domains ----

// The domain's configuration: CYCLONEDDS_URI's (when set), then the options'. Every QoS is published in discovery,
// defaults too (as some vendors want, and so that a capture shows all of them).
std::string domain_config(const ParticipantOptions& o) {
  const char* env = std::getenv("CYCLONEDDS_URI");
  std::string xml = env != nullptr && *env != '\0' ? std::string(env) + "," : "";
  xml += "<CycloneDDS><Domain id=\"any\">";
  if (!o.interface.empty())
    xml += "<General><Interfaces><NetworkInterface name=\"" + o.interface + "\"/></Interfaces></General>";
  xml +=
      "<Compatibility><ExplicitlyPublishQosSetToDefault>true</ExplicitlyPublishQosSetToDefault></Compatibility>"
      "<Discovery>";
  if (!o.peers.empty()) {
    xml += "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex><Peers>";
    std::size_t at = 0;
    while (at < o.peers.size()) {
      const std::size_t end = std::min(o.peers.find(' ', at), o.peers.size());
      if (end > at) xml += "<Peer address=\"" + o.peers.substr(at, end - at) + "\"/>";
      at = end + 1;
    }
    xml += "</Peers>";
  }
  return xml + "</Discovery></Domain></CycloneDDS>";
}

// The domains this process created, by id: shared by the participants of one id, deleted with the last.
struct Domain {
  Entity handle = 0;
  std::string config;
  int users = 0;
};
std::mutex domains_mutex;
std::map<std::uint32_t, Domain> domains;

void acquire_domain(const ParticipantOptions& o) {
  const std::string config = domain_config(o);
  std::lock_guard lock(domains_mutex);
  auto it = domains.find(o.domain);
  if (it != domains.end()) {
    if (it->second.config != config)
      throw std::runtime_error("DDS domain " + std::to_string(o.domain) +
                               " is already used in this process with other interface or peers options");
    ++it->second.users;
    return;
  }
  Domain d{.handle = dds_create_domain(o.domain, config.c_str()), .config = config, .users = 1};
  if (d.handle < 0)
    throw std::runtime_error("DDS domain " + std::to_string(o.domain) + ": " + dds_strretcode(d.handle) +
                             " (interface '" + o.interface + "', peers '" + o.peers + "')");
  domains[o.domain] = d;
}

void release_domain(std::uint32_t id) {
  std::lock_guard lock(domains_mutex);
  auto it = domains.find(id);
  if (it == domains.end() || --it->second.users > 0) return;
  dds_delete(it->second.handle);
  domains.erase(it);
}

// Cyclone's security plugins: beside libddsc (Debian puts them in libddsc0debian/ there), else by name.
std::string plugin(const char* name) {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&dds_create_participant), &info) != 0 && info.dli_fname != nullptr) {
    const std::filesystem::path dir = std::filesystem::path(info.dli_fname).parent_path();
    for (const auto& p :
         {dir / "libddsc0debian" / (std::string("lib") + name + ".so"), dir / (std::string("lib") + name + ".so")})
      if (std::filesystem::exists(p)) return p.string();
  }
  return name;
}

// The DDS Security properties of an SROS2 enclave directory (as rmw_cyclonedds sets them).
void security_qos(dds_qos_t* q, const std::string& dir) {
  static const char* files[] = {"identity_ca.cert.pem",    "cert.pem",       "key.pem",
                                "permissions_ca.cert.pem", "governance.p7s", "permissions.p7s"};
  for (const char* f : files)
    if (!std::filesystem::exists(std::filesystem::path(dir) / f))
      throw std::runtime_error("security: the enclave " + dir + " has no " + f);
  const std::string at = "file:" + std::filesystem::absolute(dir).string() + "/";
  const std::pair<const char*, std::string> props[] = {
      {"dds.sec.auth.library.path", plugin("dds_security_auth")},
      {"dds.sec.auth.library.init", "init_authentication"},
      {"dds.sec.auth.library.finalize", "finalize_authentication"},
      {"dds.sec.crypto.library.path", plugin("dds_security_crypto")},
      {"dds.sec.crypto.library.init", "init_crypto"},
      {"dds.sec.crypto.library.finalize", "finalize_crypto"},
      {"dds.sec.access.library.path", plugin("dds_security_ac")},
      {"dds.sec.access.library.init", "init_access_control"},
      {"dds.sec.access.library.finalize", "finalize_access_control"},
      {"dds.sec.auth.identity_ca", at + "identity_ca.cert.pem"},
      {"dds.sec.auth.identity_certificate", at + "cert.pem"},
      {"dds.sec.auth.private_key", at + "key.pem"},
      {"dds.sec.access.permissions_ca", at + "permissions_ca.cert.pem"},
      {"dds.sec.access.governance", at + "governance.p7s"},
      {"dds.sec.access.permissions", at + "permissions.p7s"},
  };
  for (const auto& [name, value] : props) dds_qset_prop(q, name, value.c_str());
}

std::string user_data_qos(dds_qos_t* q, const std::string& text) {
  dds_qset_userdata(q, text.data(), text.size());
  return text;
}

}  // namespace

std::string enclave_of(std::string_view dir) {
  while (dir.size() > 1 && dir.back() == '/') dir.remove_suffix(1);
  const std::size_t at = dir.rfind("/enclaves/");
  return at == std::string_view::npos ? "/" : std::string(dir.substr(at + 9));
}

std::optional<QosProfile> qos_profile(std::string_view name) {
  if (name == "default") return QosProfile{true, false, 10};
  if (name == "sensor_data") return QosProfile{false, false, 5};
  if (name == "tf_static") return QosProfile{true, true, 1};
  if (name == "transient_local") return QosProfile{true, true, 10};
  return std::nullopt;
}

std::string dds_topic(std::string_view ros, std::string* why) {
  auto fail = [why](std::string what) {
    if (why != nullptr) *why = std::move(what);
    return std::string();
  };
  if (ros.size() < 2 || ros.front() != '/') return fail("a ROS 2 topic starts with '/' and names something");
  if (ros.back() == '/') return fail("a ROS 2 topic does not end with '/'");
  bool token_start = true;
  for (const char c : ros.substr(1)) {
    const bool alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
    const bool digit = c >= '0' && c <= '9';
    if (c == '/') {
      if (token_start) return fail("a ROS 2 topic has no empty token ('//')");
      token_start = true;
    } else if (alpha || (digit && !token_start)) {
      token_start = false;
    } else {
      return fail(digit ? "a token of a ROS 2 topic does not start with a digit"
                        : std::string("a ROS 2 topic has letters, digits, '_' and '/' only, not '") + c + "'");
    }
  }
  return "rt" + std::string(ros);
}

Participant::Participant(const ParticipantOptions& options) : domain_(options.domain) {
  acquire_domain(options);
  dds_qos_t* q = dds_create_qos();
  const std::string enclave = options.security.empty() ? options.enclave : enclave_of(options.security);
  user_data_qos(q, "enclave=" + enclave + ";");
  try {
    if (!options.security.empty()) security_qos(q, options.security);
  } catch (...) {
    dds_delete_qos(q);
    release_domain(domain_);
    throw;
  }
  participant_ = dds_create_participant(options.domain, q, nullptr);
  dds_delete_qos(q);
  if (participant_ < 0) {
    const std::string why = dds_strretcode(participant_);
    release_domain(domain_);
    throw std::runtime_error("DDS participant in domain " + std::to_string(options.domain) + ": " + why +
                             (options.security.empty() ? std::string()
                                                       : " (security enclave " + options.security +
                                                             ": Cyclone's reason is in the lines above)"));
  }
}

Participant::~Participant() {
  dds_delete(participant_);
  release_domain(domain_);
}

Gid Participant::gid() const { return gid_of(participant_); }

Endpoint Participant::writer(const std::string& topic, std::string_view type, std::string_view type_hash,
                             QosProfile qos) {
  return endpoint(true, topic, type, type_hash, qos);
}

Endpoint Participant::reader(const std::string& topic, std::string_view type, std::string_view type_hash,
                             QosProfile qos) {
  return endpoint(false, topic, type, type_hash, qos);
}

Endpoint Participant::endpoint(bool writer, const std::string& topic, std::string_view type, std::string_view type_hash,
                               QosProfile qos) {
  ddsi_sertype* st = raw_sertype(type);
  Endpoint e;
  e.topic = dds_create_topic_sertype(participant_, topic.c_str(), &st, nullptr, nullptr, nullptr);
  if (e.topic < 0) {
    ddsi_sertype_unref(st);
    throw std::runtime_error("DDS topic " + topic + " of " + std::string(type) + ": " + dds_strretcode(e.topic));
  }
  e.sertype = st;  // the topic's (Cyclone may have given an equal one it had): valid while the topic is
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, qos.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_SECS(1));
  dds_qset_durability(q, qos.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, qos.depth);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q, 1, &xcdr1);
  if (!type_hash.empty()) user_data_qos(q, "typehash=" + std::string(type_hash) + ";");
  e.handle = writer ? dds_create_writer(participant_, e.topic, q, nullptr)
                    : dds_create_reader(participant_, e.topic, q, nullptr);
  dds_delete_qos(q);
  if (e.handle < 0)
    throw std::runtime_error(std::string("DDS ") + (writer ? "writer" : "reader") + " of " + topic + ": " +
                             dds_strretcode(e.handle));
  e.gid = gid_of(e.handle);
  return e;
}

Gid gid_of(Entity e) {
  dds_guid_t g{};
  Gid out{};
  if (dds_get_guid(e, &g) == DDS_RETCODE_OK) std::memcpy(out.data(), g.v, out.size());
  return out;
}

bool write(const Endpoint& writer, std::span<const std::byte> cdr) {
  if (writer.sertype == nullptr) return false;
  RawSerdata* d = make_serdata(static_cast<const ddsi_sertype*>(writer.sertype), SDK_DATA, cdr.size());
  if (!cdr.empty()) std::memcpy(d->bytes.data(), cdr.data(), cdr.size());
  return dds_writecdr(writer.handle, d) >= 0;  // takes our reference
}

std::size_t take(const Endpoint& reader, const std::function<void(std::span<const std::byte>)>& f) {
  std::size_t n = 0;
  std::vector<unsigned char> buf;
  for (;;) {
    ddsi_serdata* d = nullptr;
    dds_sample_info_t info;
    if (dds_takecdr(reader.handle, &d, 1, &info, DDS_ANY_STATE) <= 0) break;
    if (info.valid_data) {
      const uint32_t size = ddsi_serdata_size(d);
      buf.resize(size);
      ddsi_serdata_to_ser(d, 0, size, buf.data());
      f(std::as_bytes(std::span(buf)));
      ++n;
    }
    ddsi_serdata_unref(d);
  }
  return n;
}

WaitSet::WaitSet(const Participant& p) {
  waitset_ = dds_create_waitset(p.handle());
  guard_ = dds_create_guardcondition(p.handle());
  if (waitset_ < 0 || guard_ < 0) throw std::runtime_error("DDS waitset: " + std::string(dds_strretcode(waitset_)));
  dds_waitset_attach(waitset_, guard_, guard_);
}

WaitSet::~WaitSet() {
  for (const Entity c : conditions_) dds_delete(c);
  dds_delete(guard_);
  dds_delete(waitset_);
}

void WaitSet::add(const Endpoint& reader) {
  const Entity c = dds_create_readcondition(reader.handle, DDS_ANY_STATE);
  if (c < 0) throw std::runtime_error("DDS read condition: " + std::string(dds_strretcode(c)));
  conditions_.push_back(c);
  dds_waitset_attach(waitset_, c, c);
}

void WaitSet::wait(std::int64_t timeout_ms) {
  dds_waitset_wait(waitset_, nullptr, 0, DDS_MSECS(timeout_ms));
  dds_set_guardcondition(guard_, false);
}

void WaitSet::wake() { dds_set_guardcondition(guard_, true); }

}  // namespace dca::ros2
