// The PTZ service's replies read into plain structs: the nodes (spaces, limits, presets, home),
// the configuration options, the status (position, moving or not, camera time), the presets.
// Values are in the units of the space the camera names (the generic spaces: pan and tilt
// -1..1, zoom 0..1); every number is finite and within kMaxSpaceValue, every text short and
// without control characters; a missing or bad field is an Error naming it and its value.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ptz_driver/heads/onvif/soap.hpp"

namespace ptz::onvif {

// No space's value is beyond this (degrees spaces go to 360, generic ones to 1).
constexpr double kMaxSpaceValue = 1e6;
constexpr std::size_t kMaxPresets = 1024;
constexpr std::size_t kMaxNodes = 16;

struct Range {
  double min = 0.0;
  double max = 0.0;
};
// A space: its URI and the ranges of x (pan or zoom) and y (tilt; zero for a 1-D space).
struct Space {
  std::string uri;
  Range x;
  Range y;
};
// The first space of each kind the camera lists (tt:PTZSpaces).
struct PtzSpaces {
  std::optional<Space> absolute_pan_tilt;
  std::optional<Space> absolute_zoom;
  std::optional<Space> relative_pan_tilt;
  std::optional<Space> relative_zoom;
  std::optional<Space> continuous_pan_tilt_velocity;
  std::optional<Space> continuous_zoom_velocity;
  std::optional<Space> pan_tilt_speed;
  std::optional<Space> zoom_speed;
};

struct PtzNode {
  std::string token;
  std::string name;
  PtzSpaces spaces;
  int max_presets = 0;
  bool home_supported = false;
};
Result<std::vector<PtzNode>> parseNodes(std::string_view reply);

struct PtzConfigurationOptions {
  PtzSpaces spaces;
  std::optional<Range> timeout_s;  // PTZTimeout Min/Max
};
Result<PtzConfigurationOptions> parseConfigurationOptions(std::string_view reply);

enum class MoveState { kUnknown, kIdle, kMoving };
struct PtzStatus {
  // tt:Position; absent parts stay empty.
  std::optional<double> pan;
  std::optional<double> tilt;
  std::optional<double> zoom;
  MoveState pan_tilt_move = MoveState::kUnknown;
  MoveState zoom_move = MoveState::kUnknown;
  std::optional<double> camera_utc_s;  // UtcTime
};
Result<PtzStatus> parseStatus(std::string_view reply);

struct Preset {
  std::string token;
  std::string name;
  std::optional<double> pan;
  std::optional<double> tilt;
  std::optional<double> zoom;
};
Result<std::vector<Preset>> parsePresets(std::string_view reply);
// SetPresetResponse: the preset's token.
Result<std::string> parseSetPreset(std::string_view reply);
// A reply without content (AbsoluteMove, RelativeMove, ContinuousMove, Stop, GotoPreset):
// checked to be `response_name` in the PTZ namespace (or a fault).
Result<bool> parseEmptyPtzReply(std::string_view reply, std::string_view response_name);

}  // namespace ptz::onvif
