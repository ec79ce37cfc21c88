#include "link_frames.h"

#include <sstream>
#include <vector>

#include <dca/registry.h>

#include "stamp.h"

namespace dca::ros2 {
namespace {

const Param<std::string> kFramesParam{
    .name = "frames",
    .doc = "the frames of links.frames in order: rows 'PARENT CHILD' separated by ';' (at most 32)"};
const InSpec<Eigen::VectorXd> kFrames{.name = "Frames", .units = "m, unit quaternion", .device = "links.frames"};
const OutSpec<msgs::TFMessage> kTf{.name = "Tf"};

constexpr Eigen::Index kPerFrame = 7;  // x y z qx qy qz qw

}  // namespace

Manifest LinkFrames::Describe() {
  return {.type = "LinkFrames",
          .doc = "a URDF world's link frames as one tf2_msgs/msg/TFMessage (for /tf: docs/ros2.md)",
          .inputs = {kFrames},
          .outputs = {kTf},
          .params = {kFramesParam, PeriodParam(0.02)},
          .ends = Ending::Never()};
}

LinkFrames::LinkFrames(const ControllerContext& ctx) : PeriodicController(ctx), in_(port(kFrames)), out_(port(kTf)) {
  std::stringstream rows(param(kFramesParam));
  std::string row;
  for (int n = 1; std::getline(rows, row, ';'); ++n) {
    std::stringstream words(row);
    std::vector<std::string> w;
    for (std::string word; words >> word;) w.push_back(word);
    if (w.empty() && rows.eof() && n > 1) break;  // a ';' last
    const std::string where = "parameter 'frames': row " + std::to_string(n) + " ('" + row + "')";
    if (w.size() != 2) throw bad_param(where + " is not 'PARENT CHILD'");
    if (msg_.transforms.size() == msgs::kMaxTransforms)
      throw bad_param(where + ": more than " + std::to_string(msgs::kMaxTransforms) + " frames");
    msgs::TransformStamped t;
    if (!t.header.frame_id.assign(w[0]) || !t.child_frame_id.assign(w[1]))
      throw bad_param(where + ": a frame's name is longer than 63 bytes");
    for (const auto& other : msg_.transforms)
      if (other.child_frame_id == t.child_frame_id) throw bad_param(where + ": frame '" + w[1] + "' twice");
    msg_.transforms.push_back(t);
  }
  if (msg_.transforms.empty()) throw bad_param("parameter 'frames' names no frame");
  sample_ = Eigen::VectorXd::Zero(kPerFrame * static_cast<Eigen::Index>(msg_.transforms.size()));
}

void LinkFrames::on_start(const msgpack::object&) { have_ = false; }

void LinkFrames::MainCalc() {
  if (in_.read(sample_) == Read::New) {
    const auto want = kPerFrame * static_cast<Eigen::Index>(msg_.transforms.size());
    if (sample_.size() != want) {
      Abort("links.frames has " + std::to_string(sample_.size()) + " numbers, the parameter 'frames' names " +
            std::to_string(msg_.transforms.size()) + " frames (" + std::to_string(want) + " numbers)");
      return;
    }
    for (std::size_t i = 0; i < msg_.transforms.size(); ++i) {
      const double* f = sample_.data() + kPerFrame * static_cast<Eigen::Index>(i);
      msgs::Transform& t = msg_.transforms[i].transform;
      t.translation = {.x = f[0], .y = f[1], .z = f[2]};
      t.rotation = {.x = f[3], .y = f[4], .z = f[5], .w = f[6]};
    }
    have_ = true;
  }
  if (!have_) return;
  const msgs::Time stamp = stamp_of(now());
  for (auto& tr : msg_.transforms) tr.header.stamp = stamp;
  out_.write(msg_);
}

DCA_REGISTER_CONTROLLER(LinkFrames);

}  // namespace dca::ros2
