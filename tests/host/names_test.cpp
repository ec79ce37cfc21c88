#include "host/names.h"

#include <gtest/gtest.h>

namespace {

using dca::NameTable;
using dca::wire::Value;

TEST(NamesTest, RegisterFindRemove) {
  NameTable t;
  std::string error;
  ASSERT_TRUE(t.add("/a", Value::map().set("pid", 1), 7, &error)) << error;
  ASSERT_NE(t.find("/a"), nullptr);
  EXPECT_EQ(t.find("/a")->endpoints["pid"].as_int(), 1);
  EXPECT_EQ(t.find("/a")->owner, 7u);
  EXPECT_EQ(t.find("/b"), nullptr);
  EXPECT_TRUE(t.add("/a", Value::map().set("pid", 2), 7, &error)) << "the owner may replace its endpoints";
  EXPECT_EQ(t.find("/a")->endpoints["pid"].as_int(), 2);
  EXPECT_FALSE(t.add("/a", Value::map(), 8, &error));
  EXPECT_EQ(error, "name '/a' is already registered");
  EXPECT_FALSE(t.remove("/a", 8, &error));
  EXPECT_EQ(error, "name '/a' was registered by another process");
  EXPECT_TRUE(t.remove("/a", 7, &error));
  EXPECT_FALSE(t.remove("/a", 7, &error));
  EXPECT_EQ(error, "name '/a' is not registered");
  EXPECT_FALSE(t.add("", Value::map(), 1, &error));
  EXPECT_FALSE(t.add(std::string(1025, 'x'), Value::map(), 1, &error));
}

TEST(NamesTest, RemovingAnOwnerRemovesAllItsNames) {
  NameTable t;
  std::string error;
  t.add("/x", Value::map(), 1, &error);
  t.add("/y", Value::map(), 1, &error);
  t.add("/z", Value::map(), 2, &error);
  EXPECT_EQ(t.remove_owner(1), (std::vector<std::string>{"/x", "/y"}));
  EXPECT_EQ(t.names(), std::vector<std::string>{"/z"});
  EXPECT_EQ(t.size(), 1u);
}

TEST(NamesTest, WaitersAreTakenInOrderOnceAndCanBeCancelled) {
  NameTable t;
  t.wait("/n", 1);
  t.wait("/n", 2);
  t.wait("/m", 3);
  t.wait("/n", 4);
  EXPECT_EQ(t.waiting(), 4u);
  t.cancel_wait(2);
  t.cancel_wait(99);  // unknown: no effect
  EXPECT_EQ(t.take_waiters("/n"), (std::vector<NameTable::Waiter>{1, 4}));
  EXPECT_TRUE(t.take_waiters("/n").empty());
  EXPECT_EQ(t.waiting(), 1u);
  EXPECT_EQ(t.take_waiters("/m"), std::vector<NameTable::Waiter>{3});
  EXPECT_EQ(t.waiting(), 0u);
}

}  // namespace
