// The C++ side of the ros2.cdr_bytes test (cdr_bytes.mjs is the other):
//   ros2_msgs_samples write DIR   for every message type, DIR/<pkg>.msg.<T>.cdr (dca's CDR of its sample),
//                                 DIR/<pkg>.msg.<T>.json (the sample's values) and DIR/<pkg>.msg.<T>.msg (its
//                                 ros2msg definition, the MCAP ros2 profile's schema)
//   ros2_msgs_samples read DIR    decodes DIR/<pkg>.msg.<T>.node.cdr (written by @foxglove/rosmsg2-serialization
//                                 from the JSON) and checks it is the sample, and its bytes are dca's
#include <dca/msgs.h>
#include <dca/msgs_cdr.h>
#include <dca/msgs_describe.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "samples.h"

namespace {

using namespace dca::msgs;

template <class M>
std::string file(const std::string& dir, const char* ext) {
  std::string name(M::ros_name);
  for (char& c : name) c = c == '/' ? '.' : c;
  return dir + "/" + name + ext;
}

template <class M>
bool write(const std::string& dir) {
  const M m = testing::sample<M>();
  std::vector<std::byte> b(cdr_max_size<M>);
  b.resize(cdr_encode(m, b));
  std::ofstream(file<M>(dir, ".cdr"), std::ios::binary).write(reinterpret_cast<const char*>(b.data()),
                                                               static_cast<std::streamsize>(b.size()));
  std::ofstream(file<M>(dir, ".json")) << to_json(m) << "\n";
  std::ofstream(file<M>(dir, ".msg")) << ros2msg_definition<M>();
  return !b.empty();
}

template <class M>
bool read(const std::string& dir) {
  std::ifstream in(file<M>(dir, ".node.cdr"), std::ios::binary);
  if (!in) return std::cout << M::ros_name << ": no .node.cdr\n", false;
  std::ostringstream all;
  all << in.rdbuf();
  const std::string s = all.str();
  const std::span<const std::byte> b(reinterpret_cast<const std::byte*>(s.data()), s.size());
  M m;
  const CdrResult r = cdr_decode(b, m);
  if (!r) return std::cout << M::ros_name << ": " << to_string(r.error) << " at " << r.offset << "\n", false;
  if (!(m == testing::sample<M>())) return std::cout << M::ros_name << ": decoded " << to_json(m) << "\n", false;
  std::vector<std::byte> mine(cdr_max_size<M>);
  mine.resize(cdr_encode(m, mine));
  if (!std::equal(mine.begin(), mine.end(), b.begin(), b.end()))
    return std::cout << M::ros_name << ": other bytes than dca's\n", false;
  std::cout << M::ros_name << ": node's " << b.size() << " bytes decoded to the sample\n";
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: ros2_msgs_samples write|read DIR\n";
    return 2;
  }
  const std::string mode = argv[1], dir = argv[2];
  bool ok = true;
  for_each_message_type([&]<class M>() { ok = (mode == "write" ? write<M>(dir) : read<M>(dir)) && ok; });
  return ok ? 0 : 1;
}
