// libFuzzer harness: BVH text (io/bvh.h). A file that parses must also convert to a clip, write
// back, and read back with the same structure; anything else must be refused with mosyn::Error.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "fuzz_check.h"
#include "io/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mosyn;
  const std::string text(reinterpret_cast<const char*>(data), size);
  io::BvhFile bvh;
  try {
    bvh = io::parse_bvh(text, "fuzz.bvh");
  } catch (const Error&) {
    return 0;  // refused with a message: fine
  }
  // Accepted: the rest of the pipeline must cope. Rotations may be huge (1e300 degrees) and
  // skeletons odd (zero-length bones); none of it may crash.
  try {
    const Clip clip = io::to_clip(bvh);
    const io::BvhFile again = io::parse_bvh(io::format_bvh(io::from_clip(clip, &bvh), 17), "again.bvh");
    FUZZ_CHECK(again.num_frames == bvh.num_frames);
    FUZZ_CHECK(again.skeleton.joint_names == bvh.skeleton.joint_names);
    FUZZ_CHECK(again.channels == bvh.channels);
  } catch (const Error&) {
  }
  return 0;
}
