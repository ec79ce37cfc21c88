#include "host/version.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace {

TEST(VersionTest, IsTheProjectVersion) {
  const std::string v(dca::version());
  EXPECT_FALSE(v.empty());
  EXPECT_EQ(std::count(v.begin(), v.end(), '.'), 2) << v;
}

}  // namespace
