#pragma once
// host/codec: pure encoders and decoders. No Asio, no Beast, no socket, nothing of host/net or host/web.
// A robot's link frames and description as Foxglove's 3D panel reads them (docs/recording.md, "Link frames"):
//   - foxglove.FrameTransforms, JSON: {"transforms": [{timestamp {sec, nsec}, parent_frame_id, child_frame_id,
//     translation {x, y, z}, rotation {x, y, z, w}}, ...]}, one transform per link (its frame in its parent's);
//   - the URDF's text on /robot_description: {"data": URDF}, schema name std_msgs/String (what the 3D panel's
//     URDF layer subscribes to on that topic).
// Frames travel between the world and the viewers as one vector of numbers, 7 per frame: x y z (m), then the
// unit quaternion qx qy qz qw (the world's port links.frames, topic /world/links/frames). C++17-clean.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace dca::frames {

inline constexpr const char* kSchemaName = "foxglove.FrameTransforms";
inline constexpr const char* kDescriptionTopic = "/robot_description";
inline constexpr const char* kDescriptionSchemaName = "std_msgs/String";
/// Numbers per frame in a frames vector.
inline constexpr std::size_t kValuesPerFrame = 7;

/// A frame: `child` placed in `parent`.
struct Frame {
  std::string parent, child;
};

/// The JSON Schema of foxglove.FrameTransforms.
const std::string& json_schema();
/// One foxglove.FrameTransforms message at `t_ns`: frames[i] from values[7 i .. 7 i + 6] (frames past the
/// values' end are left out; non-finite numbers are null).
std::string message(const std::vector<Frame>& frames, std::int64_t t_ns, const double* values, std::size_t n);
/// The JSON Schema of the /robot_description messages: {"data": string}.
const std::string& description_schema();
/// The /robot_description message of URDF text `urdf`.
std::string description_message(const std::string& urdf);

}  // namespace dca::frames
