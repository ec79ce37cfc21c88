// The configuration repository: write rate on one replica and catch-up time of a replica that missed 10,000
// writes, beside raw SQLite inserts in the same run (same directory, WAL mode, same synchronous setting), blocks
// alternating. Prints RESULT lines (BENCHMARKS.md); progress on stderr.
//   bench_config [writes_per_block] [blocks] [catchup_writes] [dir]
//
//   config_write/store_<sync>    ConfigStore::set of one key: one transaction (its row in the log; the key
//                                table every 256th), committed
//   config_write/daemon_full     config_set over an authenticated channel to an in-process daemon, acked after
//                                commit, one request in flight (a daemon's replica is always synchronous=FULL)
//   raw_sqlite_insert/<sync>     INSERT OR REPLACE of one (key, blob) row in its own transaction
//   config_catchup/<n>_txns      a fresh daemon peered with one holding n transactions: from its start to
//                                holding all n (anti-entropy over loopback TCP, batches of 2000)
//   raw_sqlite_bulk/<n>_rows     the same n rows inserted in transactions of 2000 (the storage floor)
#include <sqlite3.h>
#include <unistd.h>

#include "host/loop.h"  // first: Asio with GCC 12's false positive silenced
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "host/config_store.h"
#include "host/daemon.h"
#include "tests/bench/bench_util.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
using dca::wire::Message;
using dca::wire::Value;

const std::string kKey = "benchmark key, 32 bytes long....";

double us_since(Clock::time_point t0) { return std::chrono::duration<double, std::micro>(Clock::now() - t0).count(); }

void report(const std::string& bench, const std::string& variant, std::vector<double> us, const std::string& extra) {
  dca::bench::result(bench, variant, us, extra);
}

std::string rate(const std::vector<double>& us, const char* name) {
  double total = 0;
  for (double x : us) total += x;
  char buf[64];
  std::snprintf(buf, sizeof buf, " %s=%.0f", name, total > 0 ? 1e6 * static_cast<double>(us.size()) / total : 0.0);
  return buf;
}

void check(bool ok, const std::string& what) {
  if (!ok) {
    std::fprintf(stderr, "bench_config: %s\n", what.c_str());
    std::exit(1);
  }
}

struct Raw {
  sqlite3* db = nullptr;
  sqlite3_stmt* ins = nullptr;
  Raw(const std::string& path, bool full) {
    check(sqlite3_open(path.c_str(), &db) == SQLITE_OK, "open " + path);
    sqlite3_exec(db, "PRAGMA journal_mode=WAL", nullptr, nullptr, nullptr);
    sqlite3_exec(db, full ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL", nullptr, nullptr, nullptr);
    sqlite3_exec(db, "CREATE TABLE IF NOT EXISTS kv(key TEXT PRIMARY KEY, value BLOB)", nullptr, nullptr, nullptr);
    check(sqlite3_prepare_v2(db, "INSERT OR REPLACE INTO kv VALUES(?1, ?2)", -1, &ins, nullptr) == SQLITE_OK, "prepare");
  }
  ~Raw() {
    sqlite3_finalize(ins);
    sqlite3_close(db);
  }
  void insert(const std::string& key, const std::string& blob) {
    sqlite3_bind_text(ins, 1, key.data(), static_cast<int>(key.size()), SQLITE_TRANSIENT);
    sqlite3_bind_blob(ins, 2, blob.data(), static_cast<int>(blob.size()), SQLITE_TRANSIENT);
    check(sqlite3_step(ins) == SQLITE_DONE, "insert");
    sqlite3_reset(ins);
  }
};

void raw_block(Raw& raw, int n, int base, std::vector<double>* out) {
  std::string blob;
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    blob.clear();
    dca::wire::encode_value(Value(base + i), blob);
    sqlite3_exec(raw.db, "BEGIN", nullptr, nullptr, nullptr);
    raw.insert("bench.k" + std::to_string(i % 100), blob);
    sqlite3_exec(raw.db, "COMMIT", nullptr, nullptr, nullptr);
    out->push_back(us_since(t0));
  }
}

void store_block(dca::config::ConfigStore& s, int n, int base, std::vector<double>* out) {
  for (int i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    std::string e;
    check(s.set({{"bench.k" + std::to_string(i % 100), Value(base + i)}}, nullptr, &e).has_value(), e);
    out->push_back(us_since(t0));
  }
}

void daemon_block(dca::Loop& loop, const dca::Channel::Ptr& ch, int n, int base, std::vector<double>* out) {
  int done = 0;
  Clock::time_point t0;
  std::function<void()> next = [&] {
    t0 = Clock::now();
    ch->request(Message{"config_set", 0, Value::map().set("values", Value::map().set("bench.k" + std::to_string(done % 100), base + done))},
                10s, [&](dca::Response r) {
                  check(r.ok(), "config_set: " + r.error);
                  out->push_back(us_since(t0));
                  if (++done < n) next();
                });
  };
  next();
  check(loop.run_until([&] { return done >= n; }, 600s), "daemon writes timed out");
}

dca::Channel::Ptr connect(dca::Loop& loop, const dca::Address& to) {
  dca::Channel::Ptr out;
  bool done = false;
  dca::Channel::connect(loop.io(), to, dca::ChannelOptions{kKey}, [&](dca::Channel::Ptr ch, const std::string& e) {
    check(ch != nullptr, "connect: " + e);
    out = std::move(ch);
    done = true;
  });
  check(loop.run_until([&] { return done; }, 10s), "connect timed out");
  return out;
}

dca::DaemonOptions daemon_options(const std::string& host, const std::string& dir, std::vector<dca::Address> peers) {
  dca::DaemonOptions o;
  o.host = host;
  o.key = kKey;
  o.peers = std::move(peers);
  o.state_dir = dir;
  o.config_sync_interval = 1000ms;
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  const int per_block = argc > 1 ? std::atoi(argv[1]) : 300;
  const int blocks = argc > 2 ? std::atoi(argv[2]) : 4;
  const int catchup = argc > 3 ? std::atoi(argv[3]) : 10000;
  const fs::path root = fs::path(argc > 4 ? argv[4] : (std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp")) /
                        ("dca_bench_config_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  std::fprintf(stderr, "bench_config: %d writes x %d blocks per variant, catch-up of %d, in %s\n", per_block, blocks,
               catchup, root.c_str());

  // --- write rate: raw SQLite, the store, the daemon; synchronous FULL and NORMAL; blocks alternating
  for (const bool full : {true, false}) {
    const std::string sync = full ? "full" : "normal";
    std::vector<double> raw_us, store_us, daemon_us;
    Raw raw((root / ("raw_" + sync + ".db")).string(), full);
    dca::config::StoreOptions so;
    so.path = (root / ("store_" + sync + ".db")).string();
    so.host = "bench";
    so.sync_full = full;
    std::string e;
    auto store = dca::config::ConfigStore::open(so, &e);
    check(store != nullptr, e);
    dca::Loop loop;
    auto o = daemon_options("bench", (root / ("daemon_" + sync)).string(), {});
    dca::Daemon d(loop.io(), o);
    check(d.start(&e), e);
    auto ch = connect(loop, d.address());
    for (int b = 0; b < blocks; ++b) {
      std::fprintf(stderr, "  %s block %d/%d\n", sync.c_str(), b + 1, blocks);
      raw_block(raw, per_block, b * per_block, &raw_us);
      store_block(*store, per_block, b * per_block, &store_us);
      if (full) daemon_block(loop, ch, per_block, b * per_block, &daemon_us);
    }
    ch->close();
    d.stop();
    report("raw_sqlite_insert", sync, raw_us, rate(raw_us, "writes_per_s"));
    report("config_write", "store_" + sync, store_us, rate(store_us, "writes_per_s"));
    if (full) report("config_write", "daemon_" + sync, daemon_us, rate(daemon_us, "writes_per_s"));
  }

  // --- catch-up: a replica that missed `catchup` writes, three times, beside bulk raw inserts
  std::vector<double> catch_us, bulk_us;
  for (int rep = 0; rep < 3; ++rep) {
    std::fprintf(stderr, "  catch-up %d/3\n", rep + 1);
    const fs::path dir = root / ("catchup" + std::to_string(rep));
    {
      dca::config::StoreOptions so;
      so.path = (dir / "a" / "config.db").string();
      so.host = "a";
      so.sync_full = false;
      fs::create_directories(dir / "a");
      std::string e;
      auto s = dca::config::ConfigStore::open(so, &e);
      check(s != nullptr, e);
      for (int i = 0; i < catchup; ++i) check(s->set({{"bulk.k" + std::to_string(i), Value(i)}}, nullptr, &e).has_value(), e);
    }
    {
      Raw raw((dir / "raw_bulk.db").string(), true);
      std::string blob;
      const auto t0 = Clock::now();
      for (int i = 0; i < catchup; i += 2000) {
        sqlite3_exec(raw.db, "BEGIN", nullptr, nullptr, nullptr);
        for (int j = i; j < std::min(catchup, i + 2000); ++j) {
          blob.clear();
          dca::wire::encode_value(Value(j), blob);
          raw.insert("bulk.k" + std::to_string(j), blob);
        }
        sqlite3_exec(raw.db, "COMMIT", nullptr, nullptr, nullptr);
      }
      bulk_us.push_back(us_since(t0));
    }
    dca::Loop loop;
    std::string e;
    dca::Daemon a(loop.io(), daemon_options("a", (dir / "a").string(), {}));
    check(a.start(&e), e);
    const auto t0 = Clock::now();
    dca::Daemon b(loop.io(), daemon_options("b", (dir / "b").string(), {a.address()}));
    check(b.start(&e), e);
    check(loop.run_until([&] { return b.config()->store()->transactions() >= static_cast<std::uint64_t>(catchup); }, 300s),
          "catch-up timed out");
    catch_us.push_back(us_since(t0));
    b.stop();
    a.stop();
  }
  const std::string n = std::to_string(catchup);
  report("config_catchup", n + "_txns", catch_us,
         " txns_per_s=" + std::to_string(static_cast<long>(1e6 * catchup / *std::min_element(catch_us.begin(), catch_us.end()))));
  report("raw_sqlite_bulk", n + "_rows_full", bulk_us,
         " rows_per_s=" + std::to_string(static_cast<long>(1e6 * catchup / *std::min_element(bulk_us.begin(), bulk_us.end()))));
  fs::remove_all(root);
  return 0;
}
