// The project's LCM messages as JSON, field for field under the names of the .lcm files, for
// Foxglove's plots and raw-message panels and for PlotJuggler. A process status keys its channels
// and counters by name (`counters.frames_published`), so a plot path names them directly.
// Numbers that are not finite become null (JSON has no NaN).
#pragma once

#include <nlohmann/json.hpp>

#include "ptzstereo/control_state_t.hpp"
#include "ptzstereo/object_detections_t.hpp"
#include "ptzstereo/object_pose_t.hpp"
#include "ptzstereo/object_tracks_t.hpp"
#include "ptzstereo/process_status_t.hpp"
#include "ptzstereo/ptz_setpoint_t.hpp"
#include "ptzstereo/ptz_state_t.hpp"
#include "ptzstereo/sim_truth_t.hpp"
#include "ptzstereo/target_select_t.hpp"

namespace ptz::foxglove {

nlohmann::json toJson(const ptzstereo::ptz_state_t& m);
nlohmann::json toJson(const ptzstereo::ptz_setpoint_t& m);
nlohmann::json toJson(const ptzstereo::control_state_t& m);
nlohmann::json toJson(const ptzstereo::object_detections_t& m);
nlohmann::json toJson(const ptzstereo::object_pose_t& m);
nlohmann::json toJson(const ptzstereo::object_tracks_t& m);
nlohmann::json toJson(const ptzstereo::sim_truth_t& m);
nlohmann::json toJson(const ptzstereo::target_select_t& m);
nlohmann::json toJson(const ptzstereo::process_status_t& m);

// A JSON Schema (draft 2020-12 subset) for the JSON of a message like `sample`: objects with their
// properties, arrays with the schema of their first element (so the sample holds one element in
// each array), numbers that may be null. `maps` names the properties (by path, "counters") that
// are objects keyed by name, whose values look like the sample's first one.
nlohmann::json schemaOf(const nlohmann::json& sample, const std::string& title,
                        const std::vector<std::string>& maps = {});

// JSON text whose strings are valid UTF-8 whatever bytes the message's strings held (invalid
// bytes become U+FFFD): nlohmann's plain dump() throws on them, and LCM strings are any bytes.
std::string dumpJson(const nlohmann::json& j);

}  // namespace ptz::foxglove
