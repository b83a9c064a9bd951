// OpenSim playback of fesim trials (README "OpenSim"): the participant as an OpenSim 4 model file
// (.osim, OpenSimDocument Version 40000) and a trial's angles as an OpenSim motion file (.mot,
// Storage version 1, inDegrees=yes), so a trial plays in the OpenSim 4.x GUI.
//
// The model mirrors UpperLimbModel's kinematic chain (upper_limb_model.cc): one CustomJoint per
// coordinate with fesim's coordinate name, the pin axis as rotation1 and the two axes orthogonal
// to it as constant rotation2/3 (OpenSim needs three independent rotation axes); the joint's
// parent offset frame at the segment's distal joint centre. The massless intermediate bodies of
// the shoulder (elevation plane, elevation) and wrist (radius, carpal) are bodies of 1e-6 kg
// (kOsimFrameMassKg; OpenSim bodies carry mass). Coordinates carry the passive joint's range
// [q_min, q_max] (rad) and the scenario's initial angle; locked coordinates are locked. Each
// muscle is a Thelen2003Muscle with fesim's Hill parameters (F_max, l_opt, l_ts, φ₀, v_max) and a
// two-point path for display: fesim's moment arms are functions of the angles (Landsmeer,
// tendons/landsmeer.h), not path geometry, and only the first crossing's moment arm at zero
// angles is matched by the points' offset (OsimPathPoints).
#pragma once

#include <array>
#include <string>

#include "base/trial.h"
#include "sim/model_params.h"

namespace fesim::sim {

/// Mass given to the massless frames of the chain in the .osim, kg (inertia 1e-9 kg·m²).
inline constexpr double kOsimFrameMassKg = 1e-6;

/// The OpenSim 4 model (.osim XML text) of `model`, named `name`.
std::string FormatOsimModel(const ModelParams& model, const std::string& name);

/// OpenSim motion (.mot) text of a trial: time and every coordinate by its fesim name in
/// degrees. A coordinate without a q.<name> column in `trial` stays at the model's initial angle;
/// NaN samples (dropouts) are linearly interpolated between their finite neighbours (held at the
/// nearest one at the ends); a column with no finite sample is the initial angle.
std::string FormatOsimMotion(const Trial& trial, const ModelParams& model, const std::string& name);

/// The two display path points of a muscle: body names (SegmentNames() or a frame name) and
/// locations in those bodies, m. The points sit on the segments before the first and after the
/// last crossed joint, offset perpendicular to the first crossing's axis so that the path's
/// moment arm about it at zero angles is that crossing's d (r = −∂l/∂q; within 1 % where the
/// index MCP's lateral offset tilts the path) — unless that axis runs along the segments.
struct OsimPathPoints {
  std::string origin_body, insertion_body;
  std::array<double, 3> origin_m{}, insertion_m{};
};
OsimPathPoints MuscleDisplayPath(const ModelParams& model, const MuscleParams& muscle);

}  // namespace fesim::sim
