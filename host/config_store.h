#pragma once
// The configuration repository's replica (the paper's DBManager, decentralised): one SQLite file per daemon.
//
// Data: keys in a dotted namespace (`door.width`, `robot.arm.gains.kp`: segments of letters, digits, '_' and
// '-', starting with a letter or '_'), values any msgpack value but nil (wire::Value).
// A write is a transaction of one or more keys stamped with a hybrid logical clock: physical milliseconds, a
// logical counter and the origin replica's id, totally ordered in that order. Each replica numbers its own
// transactions 1, 2, 3... (seq); a replica holds, for each origin, a prefix 1..k of that origin's
// transactions, so its version vector {origin = k} says exactly what it has, and `missing(theirs)` gives what a
// peer lacks, ordered by stamp (a prefix of that order is closed under causality, since a write's stamp is
// above every stamp its origin had seen).
// Every replica resolves a key the same way: the highest stamp wins (last writer wins). Each write carries the
// stamp of the value it replaced at its origin; a write applied over a value it did not replace (concurrent
// writes) is a conflict, and the losing write is kept in the conflict log (the same on every replica).
//
// Durability: WAL mode with synchronous=FULL: a write is acknowledged after its commit reached the disk, so it
// survives kill -9 (and power loss). A `set` commits one row, the transaction's in the log (txns); the key table
// (kv) catches up in memory and is written every kFlushEvery transactions, in the commit of the one that reaches
// it, and at close. After a crash, the open replays the log past the key table's mark (meta 'kv_arrival'): the
// keys are what every acknowledged transaction made them, nothing is lost. A file that is not a usable dca configuration database (not SQLite,
// corrupt pages, another program's database) is refused at open with a message naming the file: never
// silently replaced by an empty replica.
//
// Not thread-safe: one owner (the daemon's loop thread).
#include <compare>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "host/codec/wire.h"

struct sqlite3;

namespace dca::config {

/// A hybrid-logical-clock stamp: totally ordered by (ms, n, origin).
struct Stamp {
  std::int64_t ms = 0;   ///< physical time, milliseconds since the Unix epoch (at least)
  std::uint32_t n = 0;   ///< logical counter within one ms
  std::string origin;    ///< the replica that wrote it
  auto operator<=>(const Stamp&) const = default;
  bool operator==(const Stamp&) const = default;
  /// "1732250000123.2@host/ab12cd34"
  std::string str() const;
  /// {ms, n, origin}
  wire::Value value() const;
  /// From {ms, n, origin}; nullopt when malformed.
  static std::optional<Stamp> from_value(const wire::Value& v);
};

/// The hybrid logical clock of one replica.
class Hlc {
 public:
  explicit Hlc(std::string origin) : origin_(std::move(origin)) {}
  /// A fresh stamp above every stamp issued or observed, given the wall clock now.
  Stamp tick(std::int64_t wall_ms);
  /// Takes a stamp seen from elsewhere into account (the next tick is above it).
  void observe(const Stamp& s);
  const std::string& origin() const { return origin_; }

 private:
  std::string origin_;
  std::int64_t ms_ = 0;
  std::uint32_t n_ = 0;
};

/// One key's write within a transaction.
struct Write {
  std::string key;
  wire::Value value;
  std::optional<Stamp> prev;  ///< the stamp of the value it replaced at its origin (none: the key was new there)
};

/// A transaction: one or more writes with one stamp.
struct Txn {
  std::string origin;     ///< = stamp.origin
  std::uint64_t seq = 0;  ///< 1, 2, 3... per origin
  Stamp stamp;
  std::vector<Write> writes;

  /// {o, s, t, c, w = [[key, value, prev | nil]...]} (the replication format).
  wire::Value value() const;
  /// From value(); nullopt with *error when malformed (keys are validated too).
  static std::optional<Txn> from_value(const wire::Value& v, std::string* error);
};

/// A key's current value.
struct Entry {
  std::string key;
  wire::Value value;
  Stamp stamp;
};

/// A write that lost to a concurrent one.
struct Conflict {
  std::string key;
  wire::Value winner_value, loser_value;
  Stamp winner, loser;
  std::int64_t at_ms = 0;  ///< when this replica saw it (wall clock)
};

/// origin -> the highest seq held (a prefix 1..seq of that origin's transactions).
using VersionVector = std::map<std::string, std::uint64_t>;
/// {origin = seq...} as a msgpack map, and back (nullopt when malformed).
wire::Value version_value(const VersionVector& vv);
std::optional<VersionVector> version_from_value(const wire::Value& v);

/// Checks a key: false, with why not in *error ("bad key 'door..width': empty name at byte 6"), when invalid.
bool valid_key(std::string_view key, std::string* error);
/// Up to `max` keys of `candidates` close to `key` (edit distance), closest first.
std::vector<std::string> suggest(std::string_view key, const std::vector<std::string>& candidates, std::size_t max = 3);

/// How a replica is opened.
struct StoreOptions {
  std::string path;                 ///< the SQLite file (created when missing)
  std::string host = "localhost";  ///< the daemon's host name: a new replica's id is "<host>/<8 random hex>"
  bool sync_full = true;            ///< synchronous=FULL (else NORMAL: still survives kill -9, not power loss)
  std::function<std::int64_t()> wall_ms;  ///< the wall clock in ms (default: the system clock)
};

/// One replica.
class ConfigStore {
 public:
  /// Opens (or creates) the replica; nullptr with *error naming the file when it cannot be used.
  static std::unique_ptr<ConfigStore> open(StoreOptions options, std::string* error);
  ~ConfigStore();
  ConfigStore(const ConfigStore&) = delete;
  ConfigStore& operator=(const ConfigStore&) = delete;

  /// This replica's id (the origin of its writes), kept in the file.
  const std::string& origin() const { return hlc_.origin(); }
  const std::string& path() const { return options_.path; }

  /// Writes `values` as one transaction, committed before it returns; the keys whose value changed go to
  /// *changes. nullopt with *error (bad key, nil value, value too large, disk error) and nothing written.
  std::optional<Txn> set(const std::vector<std::pair<std::string, wire::Value>>& values, std::vector<Entry>* changes,
                         std::string* error);
  /// The current value of `key`; nullopt with *error ("unknown key 'x' (did you mean door.width?)").
  std::optional<Entry> get(std::string_view key, std::string* error) const;
  /// Every key equal to `prefix` or below it (`door` lists door and door.*; "" lists all), sorted.
  std::vector<Entry> list(std::string_view prefix) const;
  /// Every key, sorted.
  std::vector<std::string> keys() const;

  /// What this replica holds.
  const VersionVector& version() const { return vv_; }
  /// The transactions a replica holding `theirs` lacks, in stamp order, at most `max_txns` of them and about
  /// `max_bytes` of values; *more is set when there are further ones.
  std::vector<Txn> missing(const VersionVector& theirs, std::size_t max_txns, std::size_t max_bytes, bool* more) const;
  /// Whether a replica holding `theirs` has any transaction this one lacks.
  bool lacks_from(const VersionVector& theirs) const;
  /// Applies replicated transactions (in the order given, all in one SQLite transaction): known ones are
  /// skipped, an origin's transaction after a gap is skipped with the rest of that origin. The keys whose
  /// value changed go to *changes. Returns how many were applied; on a disk error nothing is applied and
  /// *error says why (returns 0).
  std::size_t apply(const std::vector<Txn>& txns, std::vector<Entry>* changes, std::string* error);

  /// The latest `n` transactions by arrival here, newest first.
  std::vector<Txn> recent(std::size_t n) const;
  /// The latest `n` conflicts, newest first.
  std::vector<Conflict> conflicts(std::size_t n) const;
  /// How many transactions this replica holds.
  std::uint64_t transactions() const;

 private:
  struct Stmts;
  explicit ConfigStore(StoreOptions options);
  bool init(std::string* error);
  bool check_existing(std::string* error);
  bool create_schema(std::string* error);
  bool prepare_statements(std::string* error);
  bool load_state(std::string* error);
  bool exec(const char* sql, std::string* error) const;
  std::optional<Entry> current(const std::string& key) const;
  bool apply_one(const Txn& t, bool local, std::vector<Entry>* changes, std::string* error);
  /// A write `w` of `t` over the current value: staged when it wins (the higher stamp).
  void stage(const Txn& t, const Write& w, const std::optional<Entry>& cur);
  /// The end of one SQLite transaction: the key table written (and its mark) when due or `force`, committed;
  /// the staged writes become the pending ones. False, rolled back, with *error.
  bool commit(std::size_t txns, bool force, std::string* error);
  void rollback();
  bool replay_log(std::string* error);
  std::int64_t now_ms() const;

  StoreOptions options_;
  sqlite3* db_ = nullptr;
  std::unique_ptr<Stmts> st_;
  Hlc hlc_{""};
  VersionVector vv_;
  // The key table's writes not in kv yet: those committed (pending_) and those of the open SQLite transaction
  // (staged_); the arrival of the last transaction the kv table holds, and of the last one in the log.
  std::map<std::string, Entry> pending_, staged_;
  std::int64_t kv_arrival_ = 0, last_arrival_ = 0, staged_arrival_ = 0;
  std::size_t unflushed_ = 0;  // transactions committed since kv was last written
};

}  // namespace dca::config
