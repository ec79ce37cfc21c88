#include "host/net/auth.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "tests/support/temp_dir.h"

namespace {

using dca::auth::Handshake;
using dca::wire::Message;
using Role = Handshake::Role;
using State = Handshake::State;

const std::string kKey = "0123456789abcdef0123456789abcdef";

// Runs a handshake between two in-memory sides, passing each message through `tamper` (which may change it).
// Returns every message sent, in order, as (from_client, message).
struct Exchange {
  std::vector<std::pair<bool, Message>> log;
};

Exchange exchange(Handshake& client, Handshake& server,
             const std::function<void(bool from_client, Message&)>& tamper = {}) {
  Exchange run;
  std::vector<std::pair<bool, Message>> queue;
  auto push = [&](bool from_client, const Handshake::Step& s) {
    for (const auto& m : s.out) queue.emplace_back(from_client, m);
  };
  push(false, server.start());
  push(true, client.start());
  for (int guard = 0; guard < 20 && !queue.empty(); ++guard) {
    auto [from_client, m] = queue.front();
    queue.erase(queue.begin());
    if (tamper) tamper(from_client, m);
    run.log.emplace_back(from_client, m);
    if (from_client) {
      push(false, server.on_message(m));
    } else {
      push(true, client.on_message(m));
    }
  }
  return run;
}

TEST(AuthTest, SameKeyAuthenticatesBothSides) {
  Handshake c(Role::kClient, kKey), s(Role::kServer, kKey);
  const Exchange r = exchange(c, s);
  EXPECT_EQ(c.state(), State::kDone) << c.reason();
  EXPECT_EQ(s.state(), State::kDone) << s.reason();
  ASSERT_EQ(r.log.size(), 4u);
  EXPECT_EQ(r.log[0].second.type, "hello");
  EXPECT_EQ(r.log[1].second.type, "challenge");
  EXPECT_EQ(r.log[2].second.type, "proof");
  EXPECT_EQ(r.log[3].second.type, "welcome");
  EXPECT_EQ(s.peer_version(), dca::wire::kProtocolVersion);
}

TEST(AuthTest, WrongKeyIsRefusedWithAReasonOnBothSides) {
  // The client checks the server first: a client with another key refuses the server and tells it why.
  Handshake c(Role::kClient, "another key, 32 bytes long......"), s(Role::kServer, kKey);
  const Exchange r = exchange(c, s);
  EXPECT_EQ(c.state(), State::kFailed);
  EXPECT_EQ(s.state(), State::kFailed);
  EXPECT_NE(c.reason().find("key check"), std::string::npos) << c.reason();
  EXPECT_NE(s.reason().find("refused by the peer: wrong cluster key"), std::string::npos) << s.reason();
  for (const auto& [from_client, m] : r.log) EXPECT_NE(m.type, "welcome");
}

TEST(AuthTest, ServerRefusesAClientWhoseProofIsWrong) {
  // A client that passes the server's check but sends a wrong proof (e.g. a forged client).
  Handshake c(Role::kClient, kKey), s(Role::kServer, kKey);
  exchange(c, s, [](bool from_client, Message& m) {
    if (from_client && m.type == "proof") m.payload.set("mac", std::string(32, 'x'));
  });
  EXPECT_EQ(s.state(), State::kFailed);
  EXPECT_NE(s.reason().find("failed the key check"), std::string::npos) << s.reason();
  EXPECT_EQ(c.state(), State::kFailed);
  EXPECT_NE(c.reason().find("refused by the peer: wrong cluster key"), std::string::npos) << c.reason();
}

TEST(AuthTest, NoKeyIsRefused) {
  Handshake c(Role::kClient, ""), s(Role::kServer, kKey);
  const auto step = c.start();
  EXPECT_EQ(step.state, State::kFailed);
  EXPECT_EQ(c.reason(), "no cluster key");
  // A server without a key refuses every client.
  Handshake c2(Role::kClient, kKey), s2(Role::kServer, "");
  exchange(c2, s2);
  EXPECT_EQ(s2.state(), State::kFailed);
  EXPECT_EQ(c2.state(), State::kFailed);
  EXPECT_NE(c2.reason().find("no cluster key"), std::string::npos) << c2.reason();
}

TEST(AuthTest, ReplayedClientHandshakeIsRefused) {
  Handshake c(Role::kClient, kKey), s(Role::kServer, kKey);
  const Exchange recorded = exchange(c, s);
  ASSERT_EQ(s.state(), State::kDone);
  // An eavesdropper replays the client's messages to a new server connection (fresh server nonce).
  Handshake s2(Role::kServer, kKey);
  s2.start();
  Handshake::Step last;
  for (const auto& [from_client, m] : recorded.log)
    if (from_client) last = s2.on_message(m);
  EXPECT_EQ(s2.state(), State::kFailed);
  EXPECT_NE(s2.reason().find("replayed or tampered"), std::string::npos) << s2.reason();
  ASSERT_EQ(last.out.size(), 1u);
  EXPECT_EQ(last.out[0].type, "error");
}

TEST(AuthTest, ReplayedServerChallengeIsRefused) {
  Handshake c(Role::kClient, kKey), s(Role::kServer, kKey);
  const Exchange recorded = exchange(c, s);
  Handshake c2(Role::kClient, kKey);
  c2.start();  // fresh client nonce
  for (const auto& [from_client, m] : recorded.log)
    if (!from_client) c2.on_message(m);
  EXPECT_EQ(c2.state(), State::kFailed);
  EXPECT_NE(c2.reason().find("server failed the key check"), std::string::npos) << c2.reason();
}

TEST(AuthTest, TamperedNonceIsRefused) {
  Handshake c(Role::kClient, kKey), s(Role::kServer, kKey);
  exchange(c, s, [](bool from_client, Message& m) {
    if (from_client && m.type == "hello") {
      std::string n = m.payload["nonce"].as_string();
      n[0] = static_cast<char>(n[0] ^ 1);
      m.payload.set("nonce", n);
    }
  });
  EXPECT_EQ(c.state(), State::kFailed);
  EXPECT_EQ(s.state(), State::kFailed);
}

TEST(AuthTest, ReflectedNonceIsRefused) {
  const std::string fixed(32, 'n');
  Handshake c(Role::kClient, kKey, [&] { return fixed; }), s(Role::kServer, kKey, [&] { return fixed; });
  exchange(c, s);
  EXPECT_EQ(s.state(), State::kFailed);
  EXPECT_NE(s.reason().find("reflected"), std::string::npos) << s.reason();
}

TEST(AuthTest, VersionMismatchIsRefusedNamingBothVersions) {
  Handshake c(Role::kClient, kKey), s(Role::kServer, kKey);
  exchange(c, s, [](bool from_client, Message& m) {
    if (from_client && m.type == "hello") m.payload.set("version", 99);
  });
  EXPECT_EQ(s.state(), State::kFailed);
  EXPECT_NE(s.reason().find("protocol version 99 not supported"), std::string::npos) << s.reason();
  EXPECT_NE(c.reason().find("protocol version 99"), std::string::npos) << c.reason();
}

TEST(AuthTest, AMessageBeforeTheHandshakeIsRefused) {
  Handshake s(Role::kServer, kKey);
  s.start();
  const auto step = s.on_message(Message{"spawn", 1, dca::wire::Value::map()});
  EXPECT_EQ(step.state, State::kFailed);
  EXPECT_NE(s.reason().find("expected a handshake hello, got 'spawn'"), std::string::npos) << s.reason();
}

TEST(AuthTest, HmacMatchesRfc4231TestCase2) {
  const std::string mac = dca::auth::hmac_sha256("Jefe", "what do ya want for nothing?");
  std::string hex;
  for (unsigned char ch : mac) {
    char b[3];
    std::snprintf(b, sizeof b, "%02x", ch);
    hex += b;
  }
  EXPECT_EQ(hex, "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
}

class KeyFileTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_FALSE(dir_.empty()); }
  dca::test::TempDir tmp_{"auth_test"};
  std::string dir_ = tmp_.path();
};

TEST_F(KeyFileTest, CreatesAKeyOfMode0600OnFirstUse) {
  const std::string path = dir_ + "/cfg/dca/key";
  std::string error;
  const auto key = dca::auth::load_or_create_key(path, &error);
  ASSERT_TRUE(key) << error;
  EXPECT_EQ(key->size(), 64u);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  // The second use reads the same key.
  const auto again = dca::auth::load_or_create_key(path, &error);
  ASSERT_TRUE(again) << error;
  EXPECT_EQ(*again, *key);
}

TEST_F(KeyFileTest, RefusesAKeyFileReadableByOthersNamingTheFile) {
  const std::string path = dir_ + "/key";
  std::ofstream(path) << "0123456789abcdef0123456789abcdef\n";
  ::chmod(path.c_str(), 0644);
  std::string error;
  EXPECT_FALSE(dca::auth::load_key(path, &error));
  EXPECT_EQ(error, "key file " + path + " has mode 0644; it must be 0600 (chmod 600 " + path + ")");
  EXPECT_FALSE(dca::auth::load_or_create_key(path, &error)) << "never silently fixed";
  ::chmod(path.c_str(), 0600);
  const auto key = dca::auth::load_key(path, &error);
  ASSERT_TRUE(key) << error;
  EXPECT_EQ(*key, "0123456789abcdef0123456789abcdef");
}

TEST_F(KeyFileTest, MissingOrShortKeyFileIsAnError) {
  std::string error;
  EXPECT_FALSE(dca::auth::load_key(dir_ + "/none", &error));
  EXPECT_NE(error.find(dir_ + "/none"), std::string::npos) << error;
  const std::string path = dir_ + "/short";
  std::ofstream(path) << "abc";
  ::chmod(path.c_str(), 0600);
  EXPECT_FALSE(dca::auth::load_key(path, &error));
  EXPECT_NE(error.find("fewer than 16 bytes"), std::string::npos) << error;
}

TEST_F(KeyFileTest, PathComesFromFlagThenEnvironment) {
  EXPECT_EQ(dca::auth::key_file_path("/explicit"), "/explicit");
  ::setenv("DCA_KEY_FILE", "/from/env", 1);
  EXPECT_EQ(dca::auth::key_file_path(), "/from/env");
  ::unsetenv("DCA_KEY_FILE");
  ::setenv("XDG_CONFIG_HOME", "/xdg", 1);
  EXPECT_EQ(dca::auth::key_file_path(), "/xdg/dca/key");
  ::unsetenv("XDG_CONFIG_HOME");
  ::setenv("HOME", "/home/u", 1);
  EXPECT_EQ(dca::auth::key_file_path(), "/home/u/.config/dca/key");
}

}  // namespace
