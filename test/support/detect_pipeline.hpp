// ptz-detect's pipeline as its main makes it (its parameters, config/detect_default.yaml, the
// default rig, and settings as flags would set them), fed a frame again and again as a 30 Hz
// camera would send it, each frame's search for new objects after its messages.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "perception/detect/detect_params.hpp"
#include "perception/detect/detect_pipeline.hpp"

namespace ptz::test {

inline perception::DetectPipeline makeDetectPipeline(
    const std::vector<std::pair<std::string, std::string>>& set = {}) {
  Params p("ptz-detect", "test");
  declareRigParams(p);
  perception::declareDetectParams(p);
  p.parseConfigFile(PTZ_SOURCE_DIR "/config/detect_default.yaml");
  for (const auto& [name, value] : set) p.set(name, value);
  p.checkOrders();
  return perception::DetectPipeline(perception::DetectConfig::fromParams(p), rigFromParams(p));
}

// `frame` as frame *seq (then advanced) captured at 30 Hz; repeatable: as ptz-detect judges frames
// whose capture times are not the wall clock's (the next frame waits for this one's search for new
// objects), else as it judges a camera's.
inline perception::FrameOutputs feedFrame(perception::DetectPipeline* pipeline,
                                          const ptzstereo::stereo_frame_t& frame, int64_t* seq,
                                          bool repeatable = true) {
  ptzstereo::stereo_frame_t m = frame;
  m.seq = *seq;
  m.utime = 1'700'000'000'000'000 + *seq * 33'333;
  ++*seq;
  perception::FrameOutputs out;
  std::string why;
  EXPECT_TRUE(pipeline->process(m, &out, &why)) << why;
  EXPECT_TRUE(pipeline->discover(m, repeatable, &why)) << why;  // as ptz-detect once out is sent
  return out;
}

}  // namespace ptz::test
