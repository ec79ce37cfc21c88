#include "host/config_store.h"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sys/stat.h>

#include "host/net/auth.h"  // the replica id's random part

namespace dca::config {
namespace {

constexpr const char* kFormat = "dca-config 1";
// The key table is written every kFlushEvery transactions (the header's "Durability"): a crash leaves at most this
// many for the next open to replay from the log.
constexpr std::size_t kFlushEvery = 256;
constexpr std::size_t kMaxValueBytes = 1u << 20;   // one value, encoded
constexpr std::size_t kMaxKeyBytes = 256;

bool key_char(char c, bool first) {
  const bool alpha = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
  if (first) return alpha;
  return alpha || (c >= '0' && c <= '9') || c == '-';
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
      // a transposition counts as one edit
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) cur[j] = std::min(cur[j], prev[j - 1]);
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string encode(const wire::Value& v) {
  std::string out;
  wire::encode_value(v, out);
  return out;
}

wire::Value decode(const void* data, int size) {
  wire::Value v;
  if (data == nullptr || size <= 0) return v;
  if (!wire::decode_value(std::string_view(static_cast<const char*>(data), static_cast<std::size_t>(size)), v))
    return wire::Value();
  return v;
}

// A prepared statement, reset after each use.
class Stmt {
 public:
  Stmt() = default;
  Stmt(sqlite3* db, const char* sql) { prepare(db, sql); }
  bool prepare(sqlite3* db, const char* sql) {
    sqlite3_finalize(s_);
    s_ = nullptr;
    return sqlite3_prepare_v3(db, sql, -1, SQLITE_PREPARE_PERSISTENT, &s_, nullptr) == SQLITE_OK;
  }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  sqlite3_stmt* get() const { return s_; }
  explicit operator bool() const { return s_ != nullptr; }

 private:
  sqlite3_stmt* s_ = nullptr;
};

// Binds and resets a statement for one use.
struct Use {
  sqlite3_stmt* s;
  explicit Use(const Stmt& st) : s(st.get()) {}
  ~Use() {
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
  }
  Use& text(int i, std::string_view t) {
    sqlite3_bind_text(s, i, t.data(), static_cast<int>(t.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Use& blob(int i, const std::string& b) {
    sqlite3_bind_blob(s, i, b.data(), static_cast<int>(b.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Use& i64(int i, std::int64_t v) {
    sqlite3_bind_int64(s, i, v);
    return *this;
  }
  int step() { return sqlite3_step(s); }
  std::string col_text(int i) const {
    const auto* p = sqlite3_column_text(s, i);
    return p == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(sqlite3_column_bytes(s, i)));
  }
  std::int64_t col_i64(int i) const { return sqlite3_column_int64(s, i); }
  wire::Value col_value(int i) const { return decode(sqlite3_column_blob(s, i), sqlite3_column_bytes(s, i)); }
  Stamp col_stamp(int i) const {
    return Stamp{col_i64(i), static_cast<std::uint32_t>(col_i64(i + 1)), col_text(i + 2)};
  }
};

wire::Value writes_value(const std::vector<Write>& ws) {
  wire::Value::Array out;
  for (const auto& w : ws) {
    out.push_back(wire::Value(wire::Value::Array{wire::Value(w.key), w.value, w.prev ? w.prev->value() : wire::Value()}));
  }
  return wire::Value(std::move(out));
}

bool writes_from_value(const wire::Value& v, std::vector<Write>* out, std::string* error) {
  if (!v.is_array()) {
    *error = "writes are not an array";
    return false;
  }
  for (const auto& w : v.as_array()) {
    const auto& a = w.as_array();
    if (a.size() != 3 || !a[0].is_string()) {
      *error = "a write is not [key, value, prev]";
      return false;
    }
    Write x;
    x.key = a[0].as_string();
    if (!valid_key(x.key, error)) return false;
    x.value = a[1];
    if (!a[2].is_nil()) {
      x.prev = Stamp::from_value(a[2]);
      if (!x.prev) {
        *error = "bad prev stamp of '" + x.key + "'";
        return false;
      }
    }
    out->push_back(std::move(x));
  }
  return true;
}

}  // namespace

// ------------------------------------------------------------------------------------------------------ stamps

std::string Stamp::str() const { return std::to_string(ms) + "." + std::to_string(n) + "@" + origin; }

wire::Value Stamp::value() const {
  return wire::Value::map().set("ms", ms).set("n", static_cast<std::int64_t>(n)).set("origin", origin);
}

std::optional<Stamp> Stamp::from_value(const wire::Value& v) {
  if (!v.is_map() || !v["ms"].is_int() || !v["n"].is_int() || !v["origin"].is_string()) return std::nullopt;
  const auto n = v["n"].as_int();
  if (n < 0 || n > 0xffffffffll || v["origin"].as_string().empty()) return std::nullopt;
  return Stamp{v["ms"].as_int(), static_cast<std::uint32_t>(n), v["origin"].as_string()};
}

Stamp Hlc::tick(std::int64_t wall_ms) {
  if (wall_ms > ms_) {
    ms_ = wall_ms;
    n_ = 0;
  } else {
    ++n_;
  }
  return Stamp{ms_, n_, origin_};
}

void Hlc::observe(const Stamp& s) {
  if (s.ms > ms_ || (s.ms == ms_ && s.n > n_)) {
    ms_ = s.ms;
    n_ = s.n;
  }
}

wire::Value Txn::value() const {
  return wire::Value::map()
      .set("o", origin)
      .set("s", static_cast<std::int64_t>(seq))
      .set("t", stamp.ms)
      .set("c", static_cast<std::int64_t>(stamp.n))
      .set("w", writes_value(writes));
}

std::optional<Txn> Txn::from_value(const wire::Value& v, std::string* error) {
  std::string why;
  if (!v.is_map() || !v["o"].is_string() || v["o"].as_string().empty() || !v["s"].is_int() || v["s"].as_int() < 1 ||
      !v["t"].is_int() || !v["c"].is_int() || v["c"].as_int() < 0) {
    why = "a transaction is not {o, s, t, c, w}";
  } else {
    Txn t;
    t.origin = v["o"].as_string();
    t.seq = static_cast<std::uint64_t>(v["s"].as_int());
    t.stamp = Stamp{v["t"].as_int(), static_cast<std::uint32_t>(v["c"].as_int()), t.origin};
    if (writes_from_value(v["w"], &t.writes, &why)) {
      if (!t.writes.empty()) return t;
      why = "a transaction without writes";
    }
  }
  if (error != nullptr) *error = why;
  return std::nullopt;
}

wire::Value version_value(const VersionVector& vv) {
  wire::Value out = wire::Value::map();
  for (const auto& [o, s] : vv) out.set(o, static_cast<std::int64_t>(s));
  return out;
}

std::optional<VersionVector> version_from_value(const wire::Value& v) {
  if (!v.is_map()) return std::nullopt;
  VersionVector vv;
  for (const auto& [k, s] : v.as_map()) {
    if (!k.is_string() || !s.is_int() || s.as_int() < 0) return std::nullopt;
    vv[k.as_string()] = static_cast<std::uint64_t>(s.as_int());
  }
  return vv;
}

// -------------------------------------------------------------------------------------------------------- keys

// Why `key` is not a valid key, "" when it is.
static std::string key_problem(std::string_view key) {
  const std::string shown = "bad key '" + std::string(key.substr(0, 80)) + (key.size() > 80 ? "...'" : "'");
  if (key.empty()) return "bad key '': a key is one or more dotted names, e.g. door.width";
  if (key.size() > kMaxKeyBytes) return shown + ": longer than " + std::to_string(kMaxKeyBytes) + " bytes";
  bool start = true;
  for (std::size_t i = 0; i < key.size(); ++i) {
    const char c = key[i];
    if (c == '.') {
      if (start) return shown + ": empty name at byte " + std::to_string(i + 1);
      start = true;
      continue;
    }
    if (!key_char(c, start)) {
      return shown + ": " + (start && key_char(c, false) ? "a name starts with a letter or '_'" : "unexpected character") +
             " at byte " + std::to_string(i + 1) + " (names are letters, digits, '_' and '-', joined by '.')";
    }
    start = false;
  }
  if (start) return shown + ": ends with '.'";
  return "";
}

bool valid_key(std::string_view key, std::string* error) {
  std::string why = key_problem(key);
  if (why.empty()) return true;
  if (error != nullptr) *error = std::move(why);
  return false;
}

std::vector<std::string> suggest(std::string_view key, const std::vector<std::string>& candidates, std::size_t max) {
  std::vector<std::pair<std::size_t, std::string>> scored;
  const std::size_t limit = std::max<std::size_t>(2, key.size() / 3);
  for (const auto& c : candidates) {
    std::size_t d = edit_distance(key, c);
    // the same last name under another prefix is a likely mistake too (width for door.width)
    const auto last = c.substr(c.rfind('.') == std::string::npos ? 0 : c.rfind('.') + 1);
    if (last == key) d = std::min<std::size_t>(d, 1);
    if (d <= limit) scored.emplace_back(d, c);
  }
  std::sort(scored.begin(), scored.end());
  // only the closest ones: a near miss is worth naming, a list of everything within reach is not
  std::vector<std::string> out;
  for (std::size_t i = 0; i < scored.size() && i < max && scored[i].first == scored[0].first; ++i)
    out.push_back(scored[i].second);
  return out;
}

// ------------------------------------------------------------------------------------------------------- store

struct ConfigStore::Stmts {
  Stmt begin, commit, rollback;
  Stmt get_kv, put_kv, put_txn, put_conflict, list_all, list_prefix, keys, missing_of, recent, conflicts, count;
  Stmt put_mark, log_after;
};

ConfigStore::ConfigStore(StoreOptions options) : options_(std::move(options)) {}

ConfigStore::~ConfigStore() {
  // the key table brought up to the log at a clean close (a crash leaves it to the next open's replay)
  if (st_ && !pending_.empty()) {
    Use b(st_->begin);
    if (b.step() == SQLITE_DONE) {
      std::string why;
      commit(0, true, &why);
    }
  }
  st_.reset();
  if (db_ != nullptr) sqlite3_close_v2(db_);
}

std::int64_t ConfigStore::now_ms() const {
  if (options_.wall_ms) return options_.wall_ms();
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

bool ConfigStore::exec(const char* sql, std::string* error) const {
  char* msg = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &msg) == SQLITE_OK) return true;
  if (error != nullptr) *error = msg != nullptr ? msg : sqlite3_errmsg(db_);
  sqlite3_free(msg);
  return false;
}

std::unique_ptr<ConfigStore> ConfigStore::open(StoreOptions options, std::string* error) {
  std::unique_ptr<ConfigStore> s(new ConfigStore(std::move(options)));
  std::string why;
  if (!s->init(&why)) {
    if (error != nullptr) {
      *error = "configuration database " + s->options_.path + " is not usable: " + why +
               " (the daemon will not start with an empty replica in its place; move the file away to start afresh)";
    }
    return nullptr;
  }
  return s;
}

// Opens (or creates) the database, checks an existing one, then prepares the statements and loads the state.
bool ConfigStore::init(std::string* error) {
  struct stat sb {};
  const bool existed = ::stat(options_.path.c_str(), &sb) == 0 && sb.st_size > 0;
  if (sqlite3_open_v2(options_.path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    *error = db_ != nullptr ? sqlite3_errmsg(db_) : "cannot open";
    return false;
  }
  sqlite3_extended_result_codes(db_, 1);
  sqlite3_busy_timeout(db_, 5000);
  if (existed && !check_existing(error)) return false;
  const std::string mode = options_.sync_full ? "FULL" : "NORMAL";
  if (!exec("PRAGMA journal_mode=WAL", error)) return false;
  if (!exec(("PRAGMA synchronous=" + mode).c_str(), error)) return false;
  if (!existed && !create_schema(error)) return false;
  return prepare_statements(error) && load_state(error);
}

// An existing file: SQLite, not corrupt, and a dca configuration database of this format.
bool ConfigStore::check_existing(std::string* error) {
  {
    // Any page read fails on a file that is not SQLite; quick_check finds corrupt pages and indexes.
    Stmt qc(db_, "PRAGMA quick_check");
    if (!qc) {
      *error = sqlite3_errmsg(db_);
      return false;
    }
    Use u(qc);
    const int rc = u.step();
    if (rc != SQLITE_ROW) {
      *error = sqlite3_errmsg(db_);
      return false;
    }
    if (const auto r = u.col_text(0); r != "ok") {
      *error = "corrupt (" + r + ")";
      return false;
    }
  }
  Stmt fmt(db_, "SELECT v FROM meta WHERE k = 'format'");
  if (!fmt) {
    *error = "not a dca configuration database (" + std::string(sqlite3_errmsg(db_)) + ")";
    return false;
  }
  Use u(fmt);
  if (u.step() != SQLITE_ROW || u.col_text(0) != kFormat) {
    *error = "not a dca configuration database (no format '" + std::string(kFormat) + "' in its meta table)";
    return false;
  }
  return true;
}

// A new file: the tables, the format and a fresh replica id (<host>/<random>).
bool ConfigStore::create_schema(std::string* error) {
  const char* schema =
      "BEGIN;"
      "CREATE TABLE IF NOT EXISTS meta(k TEXT PRIMARY KEY, v TEXT NOT NULL);"
      "CREATE TABLE IF NOT EXISTS txns(arrival INTEGER PRIMARY KEY, origin TEXT NOT NULL, seq INTEGER NOT NULL,"
      "  ms INTEGER NOT NULL, n INTEGER NOT NULL, writes BLOB NOT NULL, UNIQUE(origin, seq));"
      "CREATE TABLE IF NOT EXISTS kv(key TEXT PRIMARY KEY, value BLOB NOT NULL, ms INTEGER NOT NULL,"
      "  n INTEGER NOT NULL, origin TEXT NOT NULL);"
      "CREATE TABLE IF NOT EXISTS conflicts(id INTEGER PRIMARY KEY, key TEXT NOT NULL,"
      "  winner BLOB, w_ms INTEGER, w_n INTEGER, w_origin TEXT, loser BLOB, l_ms INTEGER, l_n INTEGER,"
      "  l_origin TEXT, at_ms INTEGER, UNIQUE(key, l_ms, l_n, l_origin));";
  if (!exec(schema, error)) return false;
  const std::string meta = "INSERT OR IGNORE INTO meta VALUES('format', '" + std::string(kFormat) +
                           "'), ('replica', '" + options_.host + "/" + auth::random_token(4) +
                           "'), ('kv_arrival', '0'); COMMIT;";
  if (!exec(meta.c_str(), error)) {
    exec("ROLLBACK", nullptr);
    return false;
  }
  return true;
}

// The statements every operation uses, prepared once.
bool ConfigStore::prepare_statements(std::string* error) {
  st_ = std::make_unique<Stmts>();
  auto& s = *st_;
  const auto prep = [&](Stmt& st, const char* sql) { return st.prepare(db_, sql); };
  if (!prep(s.begin, "BEGIN IMMEDIATE") || !prep(s.commit, "COMMIT") || !prep(s.rollback, "ROLLBACK") ||
      !prep(s.get_kv, "SELECT value, ms, n, origin FROM kv WHERE key = ?1") ||
      !prep(s.put_kv, "INSERT OR REPLACE INTO kv(key, value, ms, n, origin) VALUES(?1, ?2, ?3, ?4, ?5)") ||
      !prep(s.put_txn, "INSERT INTO txns(origin, seq, ms, n, writes) VALUES(?1, ?2, ?3, ?4, ?5)") ||
      !prep(s.put_conflict,
            "INSERT OR IGNORE INTO conflicts(key, winner, w_ms, w_n, w_origin, loser, l_ms, l_n, l_origin, at_ms)"
            " VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)") ||
      !prep(s.list_all, "SELECT key, value, ms, n, origin FROM kv ORDER BY key") ||
      !prep(s.list_prefix,
            "SELECT key, value, ms, n, origin FROM kv WHERE key = ?1 OR substr(key, 1, length(?1) + 1) = ?1 || '.'"
            " ORDER BY key") ||
      !prep(s.keys, "SELECT key FROM kv ORDER BY key") ||
      !prep(s.missing_of, "SELECT seq, ms, n, writes FROM txns WHERE origin = ?1 AND seq > ?2 ORDER BY seq LIMIT ?3") ||
      !prep(s.recent, "SELECT origin, seq, ms, n, writes FROM txns ORDER BY arrival DESC LIMIT ?1") ||
      !prep(s.conflicts,
            "SELECT key, winner, w_ms, w_n, w_origin, loser, l_ms, l_n, l_origin, at_ms FROM conflicts"
            " ORDER BY id DESC LIMIT ?1") ||
      !prep(s.count, "SELECT count(*) FROM txns") ||
      !prep(s.put_mark, "INSERT OR REPLACE INTO meta VALUES('kv_arrival', ?1)") ||
      !prep(s.log_after, "SELECT arrival, origin, seq, ms, n, writes FROM txns WHERE arrival > ?1 ORDER BY arrival")) {
    *error = sqlite3_errmsg(db_);
    return false;
  }
  return true;
}

// The replica's id, its version vector, and the clock past every stamp it holds.
bool ConfigStore::load_state(std::string* error) {
  {
    Stmt q(db_, "SELECT v FROM meta WHERE k = 'replica'");
    Use u(q);
    if (!q || u.step() != SQLITE_ROW || u.col_text(0).empty()) {
      *error = "no replica id in its meta table";
      return false;
    }
    hlc_ = Hlc(u.col_text(0));
  }
  {
    Stmt q(db_, "SELECT origin, max(seq) FROM txns GROUP BY origin");
    Use u(q);
    while (u.step() == SQLITE_ROW) vv_[u.col_text(0)] = static_cast<std::uint64_t>(u.col_i64(1));
  }
  {
    Stmt q(db_, "SELECT ms, n, origin FROM txns ORDER BY ms DESC, n DESC LIMIT 1");
    Use u(q);
    if (u.step() == SQLITE_ROW) hlc_.observe(u.col_stamp(0));
  }
  {
    Stmt q(db_, "SELECT max(arrival) FROM txns");
    Use u(q);
    if (u.step() == SQLITE_ROW) last_arrival_ = u.col_i64(0);
  }
  // the key table's mark; none: a file written before the mark, whose key table holds the whole log
  Stmt q(db_, "SELECT v FROM meta WHERE k = 'kv_arrival'");
  Use u(q);
  kv_arrival_ = last_arrival_;
  if (q && u.step() == SQLITE_ROW) {
    const auto text = u.col_text(0);
    char* end = nullptr;
    const long long mark = std::strtoll(text.c_str(), &end, 10);
    if (text.empty() || end == nullptr || *end != '\0' || mark < 0 || mark > last_arrival_) {
      *error = "its key table's mark '" + text + "' is not an arrival of its log";
      return false;
    }
    kv_arrival_ = mark;
  }
  return replay_log(error);
}

// The transactions the key table does not hold yet (a crash after them), applied to the pending keys in their
// order of arrival, as they were when they came (their conflicts are in the file already).
bool ConfigStore::replay_log(std::string* error) {
  Use u(st_->log_after);
  u.i64(1, kv_arrival_);
  int rc = SQLITE_ROW;
  while ((rc = u.step()) == SQLITE_ROW) {
    Txn t;
    t.origin = u.col_text(1);
    t.seq = static_cast<std::uint64_t>(u.col_i64(2));
    t.stamp = Stamp{u.col_i64(3), static_cast<std::uint32_t>(u.col_i64(4)), t.origin};
    std::string why;
    if (!writes_from_value(u.col_value(5), &t.writes, &why)) {
      *error = "transaction " + std::to_string(u.col_i64(0)) + " of its log: " + why;
      return false;
    }
    for (const auto& w : t.writes) stage(t, w, current(w.key));
    ++unflushed_;
  }
  if (rc != SQLITE_DONE) {
    *error = std::string("reading its log: ") + sqlite3_errmsg(db_);
    return false;
  }
  for (auto& [k, e] : staged_) pending_[k] = std::move(e);
  staged_.clear();
  return true;
}

std::optional<Entry> ConfigStore::current(const std::string& key) const {
  if (auto it = staged_.find(key); it != staged_.end()) return it->second;
  if (auto it = pending_.find(key); it != pending_.end()) return it->second;
  Use u(st_->get_kv);
  u.text(1, key);
  if (u.step() != SQLITE_ROW) return std::nullopt;
  return Entry{key, u.col_value(0), u.col_stamp(1)};
}

bool ConfigStore::apply_one(const Txn& t, bool local, std::vector<Entry>* changes, std::string* error) {
  const auto fail = [&](const char* what) {
    *error = std::string(what) + ": " + sqlite3_errmsg(db_);
    return false;
  };
  {
    Use u(st_->put_txn);
    u.text(1, t.origin).i64(2, static_cast<std::int64_t>(t.seq)).i64(3, t.stamp.ms).i64(4, t.stamp.n);
    u.blob(5, encode(writes_value(t.writes)));
    if (u.step() != SQLITE_DONE) return fail("storing a transaction");
    staged_arrival_ = sqlite3_last_insert_rowid(db_);
  }
  for (const auto& w : t.writes) {
    const auto cur = current(w.key);
    bool wins = true;
    if (cur) {
      if (cur->stamp == t.stamp) continue;  // the same write (cannot happen: the txn is new), keep it idempotent
      wins = t.stamp > cur->stamp;
      const bool concurrent = !local && (!w.prev || *w.prev != cur->stamp);
      if (!wins || concurrent) {
        const Entry loser = wins ? *cur : Entry{w.key, w.value, t.stamp};
        const Entry winner = wins ? Entry{w.key, w.value, t.stamp} : *cur;
        Use u(st_->put_conflict);
        u.text(1, w.key).blob(2, encode(winner.value)).i64(3, winner.stamp.ms).i64(4, winner.stamp.n);
        u.text(5, winner.stamp.origin).blob(6, encode(loser.value)).i64(7, loser.stamp.ms).i64(8, loser.stamp.n);
        u.text(9, loser.stamp.origin).i64(10, now_ms());
        if (u.step() != SQLITE_DONE) return fail("storing a conflict");
      }
    }
    if (!wins) continue;
    stage(t, w, cur);
    if (changes != nullptr) changes->push_back(Entry{w.key, w.value, t.stamp});
  }
  return true;
}

void ConfigStore::stage(const Txn& t, const Write& w, const std::optional<Entry>& cur) {
  if (!cur || t.stamp > cur->stamp) staged_[w.key] = Entry{w.key, w.value, t.stamp};
}

bool ConfigStore::commit(std::size_t txns, bool force, std::string* error) {
  const bool flush = force || unflushed_ + txns >= kFlushEvery;
  const std::int64_t arrival = std::max(last_arrival_, staged_arrival_);
  if (flush) {
    for (const auto* m : {&pending_, &staged_})
      for (const auto& [k, e] : *m) {
        if (m == &pending_ && staged_.count(k)) continue;
        Use u(st_->put_kv);
        u.text(1, k).blob(2, encode(e.value)).i64(3, e.stamp.ms).i64(4, e.stamp.n).text(5, e.stamp.origin);
        if (u.step() != SQLITE_DONE) {
          *error = std::string("storing a value: ") + sqlite3_errmsg(db_);
          rollback();
          return false;
        }
      }
    Use u(st_->put_mark);
    u.text(1, std::to_string(arrival));
    if (u.step() != SQLITE_DONE) {
      *error = std::string("storing the key table's mark: ") + sqlite3_errmsg(db_);
      rollback();
      return false;
    }
  }
  Use c(st_->commit);
  if (c.step() != SQLITE_DONE) {
    *error = std::string("commit failed: ") + sqlite3_errmsg(db_);
    rollback();
    return false;
  }
  last_arrival_ = arrival;
  if (flush) {
    pending_.clear();
    kv_arrival_ = arrival;
    unflushed_ = 0;
  } else {
    for (auto& [k, e] : staged_) pending_[k] = std::move(e);
    unflushed_ += txns;
  }
  staged_.clear();
  return true;
}

void ConfigStore::rollback() {
  Use r(st_->rollback);
  r.step();
  staged_.clear();
  staged_arrival_ = last_arrival_;
}

std::optional<Txn> ConfigStore::set(const std::vector<std::pair<std::string, wire::Value>>& values,
                                    std::vector<Entry>* changes, std::string* error) {
  std::string why;
  const auto failed = [&](std::string e) -> std::optional<Txn> {
    if (error != nullptr) *error = std::move(e);
    return std::nullopt;
  };
  if (values.empty()) return failed("nothing to set");
  std::map<std::string, wire::Value> merged;  // a key named twice: the last one
  for (const auto& [k, v] : values) {
    if (std::string e; !valid_key(k, &e)) return failed(e);
    if (v.is_nil()) return failed("the value of '" + k + "' is nil (a key holds a value; nothing is deleted)");
    if (const auto size = encode(v).size(); size > kMaxValueBytes)
      return failed("the value of '" + k + "' is " + std::to_string(size) + " bytes (at most " +
                    std::to_string(kMaxValueBytes) + ")");
    merged[k] = v;
  }
  Use b(st_->begin);
  if (b.step() != SQLITE_DONE) return failed(std::string("cannot begin a transaction: ") + sqlite3_errmsg(db_));
  Txn t;
  t.origin = origin();
  const auto mine = vv_.find(origin());
  t.seq = (mine == vv_.end() ? 0 : mine->second) + 1;
  t.stamp = hlc_.tick(now_ms());
  for (auto& [k, v] : merged) {
    const auto cur = current(k);
    t.writes.push_back(Write{k, v, cur ? std::optional<Stamp>(cur->stamp) : std::nullopt});
  }
  std::vector<Entry> local;
  if (!apply_one(t, true, &local, &why)) {
    rollback();
    return failed(why);
  }
  if (!commit(1, false, &why)) return failed(why);
  vv_[origin()] = t.seq;
  if (changes != nullptr) changes->insert(changes->end(), local.begin(), local.end());
  return t;
}

std::optional<Entry> ConfigStore::get(std::string_view key, std::string* error) const {
  if (!valid_key(key, error)) return std::nullopt;
  if (auto cur = current(std::string(key))) return cur;
  if (error != nullptr) {
    std::string msg = "unknown key '" + std::string(key) + "'";
    const auto below = list(key);
    if (!below.empty()) {
      msg += ": it is a prefix of " + std::to_string(below.size()) + " key" + (below.size() == 1 ? "" : "s") + " (";
      for (std::size_t i = 0; i < below.size() && i < 3; ++i) msg += (i ? ", " : "") + below[i].key;
      msg += below.size() > 3 ? ", ...)" : ")";
    } else if (const auto close = suggest(key, keys()); !close.empty()) {
      msg += " (did you mean ";
      for (std::size_t i = 0; i < close.size(); ++i) msg += (i ? (i + 1 == close.size() ? " or " : ", ") : "") + close[i];
      msg += "?)";
    } else {
      msg += " (the repository holds " + std::to_string(keys().size()) + " keys)";
    }
    *error = msg;
  }
  return std::nullopt;
}

std::vector<Entry> ConfigStore::list(std::string_view prefix) const {
  std::string p(prefix);
  while (!p.empty() && p.back() == '.') p.pop_back();
  std::vector<Entry> out;
  const Stmt& st = p.empty() ? st_->list_all : st_->list_prefix;
  std::map<std::string, Entry> merged;
  {
    Use u(st);
    if (!p.empty()) u.text(1, p);
    while (u.step() == SQLITE_ROW) {
      auto key = u.col_text(0);
      merged[key] = Entry{key, u.col_value(1), u.col_stamp(2)};
    }
  }
  // with the writes the key table does not hold yet
  for (const auto* m : {&pending_, &staged_})
    for (const auto& [k, e] : *m)
      if (p.empty() || k == p || (k.size() > p.size() && k.compare(0, p.size(), p) == 0 && k[p.size()] == '.'))
        merged[k] = e;
  for (auto& [k, e] : merged) out.push_back(std::move(e));
  return out;
}

std::vector<std::string> ConfigStore::keys() const {
  std::vector<std::string> out;
  {
    Use u(st_->keys);
    while (u.step() == SQLITE_ROW) out.push_back(u.col_text(0));
  }
  for (const auto* m : {&pending_, &staged_})
    for (const auto& [k, e] : *m)
      if (!std::binary_search(out.begin(), out.end(), k)) out.insert(std::upper_bound(out.begin(), out.end(), k), k);
  return out;
}

bool ConfigStore::lacks_from(const VersionVector& theirs) const {
  for (const auto& [o, s] : theirs) {
    auto it = vv_.find(o);
    if (s > (it == vv_.end() ? 0 : it->second)) return true;
  }
  return false;
}

std::vector<Txn> ConfigStore::missing(const VersionVector& theirs, std::size_t max_txns, std::size_t max_bytes,
                                      bool* more) const {
  std::vector<Txn> all;
  std::vector<std::size_t> sizes;
  bool truncated = false;
  for (const auto& [o, mine] : vv_) {
    auto it = theirs.find(o);
    const std::uint64_t have = it == theirs.end() ? 0 : it->second;
    if (mine <= have) continue;
    Use u(st_->missing_of);
    u.text(1, o).i64(2, static_cast<std::int64_t>(have)).i64(3, static_cast<std::int64_t>(max_txns) + 1);
    std::size_t got = 0;
    while (u.step() == SQLITE_ROW) {
      if (++got > max_txns) {
        truncated = true;
        break;
      }
      Txn t;
      t.origin = o;
      t.seq = static_cast<std::uint64_t>(u.col_i64(0));
      t.stamp = Stamp{u.col_i64(1), static_cast<std::uint32_t>(u.col_i64(2)), o};
      std::string why;
      writes_from_value(u.col_value(3), &t.writes, &why);
      all.push_back(std::move(t));
    }
  }
  std::sort(all.begin(), all.end(), [](const Txn& a, const Txn& b) { return a.stamp < b.stamp; });
  std::size_t bytes = 0, keep = 0;
  for (; keep < all.size() && keep < max_txns; ++keep) {
    for (const auto& w : all[keep].writes) bytes += w.key.size() + encode(w.value).size() + 32;
    if (keep > 0 && bytes > max_bytes) break;
  }
  if (keep < all.size()) truncated = true;
  all.resize(keep);
  if (more != nullptr) *more = truncated;
  return all;
}

std::size_t ConfigStore::apply(const std::vector<Txn>& txns, std::vector<Entry>* changes, std::string* error) {
  VersionVector next = vv_;
  std::vector<const Txn*> todo;
  for (const auto& t : txns) {
    auto& have = next[t.origin];
    if (t.seq != have + 1) continue;  // known, or after a gap (it comes again after the missing ones)
    have = t.seq;
    todo.push_back(&t);
  }
  if (todo.empty()) return 0;
  std::string why;
  Use b(st_->begin);
  if (b.step() != SQLITE_DONE) {
    if (error != nullptr) *error = std::string("cannot begin a transaction: ") + sqlite3_errmsg(db_);
    return 0;
  }
  std::vector<Entry> local;
  for (const Txn* t : todo) {
    if (!apply_one(*t, false, &local, &why)) {
      rollback();
      if (error != nullptr) *error = why;
      return 0;
    }
  }
  if (!commit(todo.size(), false, &why)) {
    if (error != nullptr) *error = why;
    return 0;
  }
  for (const Txn* t : todo) hlc_.observe(t->stamp);
  for (auto& [o, s] : next)
    if (s > 0) vv_[o] = s;
  if (changes != nullptr) changes->insert(changes->end(), local.begin(), local.end());
  return todo.size();
}

std::vector<Txn> ConfigStore::recent(std::size_t n) const {
  std::vector<Txn> out;
  Use u(st_->recent);
  u.i64(1, static_cast<std::int64_t>(n));
  while (u.step() == SQLITE_ROW) {
    Txn t;
    t.origin = u.col_text(0);
    t.seq = static_cast<std::uint64_t>(u.col_i64(1));
    t.stamp = Stamp{u.col_i64(2), static_cast<std::uint32_t>(u.col_i64(3)), t.origin};
    std::string why;
    writes_from_value(u.col_value(4), &t.writes, &why);
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<Conflict> ConfigStore::conflicts(std::size_t n) const {
  std::vector<Conflict> out;
  Use u(st_->conflicts);
  u.i64(1, static_cast<std::int64_t>(n));
  while (u.step() == SQLITE_ROW) {
    Conflict c;
    c.key = u.col_text(0);
    c.winner_value = u.col_value(1);
    c.winner = u.col_stamp(2);
    c.loser_value = u.col_value(5);
    c.loser = u.col_stamp(6);
    c.at_ms = u.col_i64(9);
    out.push_back(std::move(c));
  }
  return out;
}

std::uint64_t ConfigStore::transactions() const {
  Use u(st_->count);
  return u.step() == SQLITE_ROW ? static_cast<std::uint64_t>(u.col_i64(0)) : 0;
}

}  // namespace dca::config
