// Adapter between the Simbody model (sim/) and the off-screen renderer (render/): turns a posed
// UpperLimbModel state into a render::Scene, and trial rows into poses (issue 8, `fesim render`).
//
// The adapter only reads poses (findStationLocationInGround and body rotations of a state
// realised to Stage::Position); it never integrates, and builds no OpenGL state.
//
// Geometry drawn (world frame W = Simbody ground G: metres, Y up, X anterior, Z right):
//   capsules[0..5]   the six segments in sim::Segment order (humerus, forearm, hand, proximal,
//                    middle, distal phalanx), each from its proximal joint centre (body origin)
//                    to p_B = (0, −length_m, 0); radius ArmSegmentRadius().
//   capsules[6]      the thorax (context only), a vertical capsule on the midline Z = 0.
//   capsules[7..12]  with a ghost pose: the six segments again, translucent (render::kGhostColour).
//   polylines[0..M)  one per muscle, in model order: origin on the proximal segment of the first
//                    joint it crosses → one via point per crossed joint → insertion on the distal
//                    segment of the last. At a joint with pin axes â_i (in G) and segment
//                    direction d̂ (in G, from the proximal towards the distal joint), the via point
//                    is offset from the joint centre along Σ_i r_i(q_i) unit(â_i × d̂), with r_i the
//                    Landsmeer moment arm (r = −∂l_MT/∂q): a muscle that shortens as q_i grows lies
//                    on the side the segment moves towards, so elbow flexors run anterior, wrist
//                    and finger flexors palmar, extensors dorsal. Axial coordinates
//                    (shoulder_rotation, pro_sup: â ∥ d̂) add no offset and no via point of their
//                    own. Offset size: max(|Σ r_i unit(â_i × d̂)|, segment radius +
//                    kMuscleClearance_m) so that paths lie on the skin at their attachment and via
//                    points; draw_on_top is set when the path passes inside any opaque capsule
//                    between them. Colour render::ActivationColour(a) or kNeutralMuscleColour
//                    without data.
//   polylines[M..)   arm support, two per band (cuff → anchor line, ring around the segment at the
//                    cuff) and two per weight-compensation cuff (line from the cuff along −gravity,
//                    ring).
//   pads             the electrode array, pad index = row·cols + col (muscles::PadGrid). A skin
//                    point (s = along_m, c = around_m) lies on the forearm surface of radius
//                    R = forearm radius + kPadLift_m at p_B = (R cos φ, −s, R sin φ), φ = c / R,
//                    in the forearm frame B (origin at the elbow, −Y along the forearm, X anterior
//                    and Z lateral at zero elbow flexion): c = 0 is the anterior midline, c < 0
//                    runs towards the volar (medial) side, c > 0 towards the dorsal side. Colour
//                    render::PulseWidthColour of the largest pulse width of the channels driving
//                    it.
//   overlay          title, time, one bar per model channel (µs), the ten joint angles (degrees).
#pragma once

#include <Simbody.h>

#include <string>
#include <vector>

#include "base/trial.h"
#include "render/scene.h"
#include "sim/upper_limb_model.h"

namespace fesim {

/// Colour of a muscle whose activation is unknown (the trial has no a.<muscle> column).
inline constexpr render::Rgba kNeutralMuscleColour{0.62f, 0.60f, 0.58f, 1.0f};
/// Colour of the thorax capsule.
inline constexpr render::Rgba kThoraxColour{0.74f, 0.76f, 0.82f, 1.0f};
/// Colour of the bone capsules.
inline constexpr render::Rgba kBoneColour{0.88f, 0.84f, 0.76f, 1.0f};
/// Colour of arm-support bands and weight-compensation cables.
inline constexpr render::Rgba kSupportColour{0.15f, 0.35f, 0.75f, 1.0f};
/// Distance of a muscle path from a segment's capsule surface at its attachments, m.
inline constexpr double kMuscleClearance_m = 0.004;
/// Height of the pads above the forearm capsule's surface (avoids depth fighting), m.
inline constexpr double kPadLift_m = 0.002;
/// Index of the thorax capsule in ArmScene's capsules.
inline constexpr int kThoraxCapsule = sim::kNumSegments;

/// What a frame shows besides the pose.
struct ArmSceneInputs {
  double time_s = 0;  ///< frame time, s (overlay, orbit camera).
  std::string title;  ///< first overlay line (e.g. the trial's file name).
  /// Overlay labels, one per model channel; empty: the model's channel names.
  std::vector<std::string> channel_names;
  /// Pulse width per model channel, µs (0–300; clamped for colours); empty: all 0.
  std::vector<double> stimulation_us;
  /// Activation per model muscle, 0–1; empty, or NaN entries: unknown (kNeutralMuscleColour).
  std::vector<double> activation;
  /// Optional second pose (the --compare trial), drawn as a translucent ghost arm; realised to
  /// Stage::Position at least. Not owned.
  const SimTK::State* ghost = nullptr;
};

/// Capsule radius of a segment, m: proportional to the segment's (humerus, forearm, hand) or the
/// hand's (phalanges) length.
double ArmSegmentRadius(const sim::ModelParams& params, int segment);

/// The scene of `posed` (realised to Stage::Position at least). Throws std::invalid_argument when
/// stimulation_us, channel_names or activation are non-empty and not one per model channel /
/// muscle.
render::Scene ArmScene(const sim::UpperLimbModel& model, const SimTK::State& posed,
                       const ArmSceneInputs& inputs);

/// A point to aim the camera at for this model, m: midway between the shoulder and the wrist in
/// `state` (realised to Stage::Position).
render::Vec3 ArmCameraTarget(const sim::UpperLimbModel& model, const SimTK::State& state);

/// The q.<coordinate> columns of a trial and the model coordinate each one drives.
struct PoseColumns {
  std::vector<int> column;      ///< index into Trial::names.
  std::vector<int> coordinate;  ///< sim::Coordinate index, same length.
};

/// Finds the q.* columns. Throws std::runtime_error naming `source` when the trial has no q.*
/// column at all, or a q.<name> whose name is not a model coordinate (listing the allowed names).
PoseColumns FindPoseColumns(const Trial& trial, const std::string& source);

/// Sets the coordinates of `state` from row `row` of `trial` (rad) and realises it to
/// Stage::Position. Coordinates without a column, or whose value is NaN, keep their value in
/// `state` (start from UpperLimbModel::MakeInitialState() for the scenario's initial posture).
void SetPoseFromTrialRow(const sim::UpperLimbModel& model, const Trial& trial,
                         const PoseColumns& columns, std::size_t row, SimTK::State* state);

/// The trial at `times` (s, non-decreasing): every column linearly interpolated between its
/// samples; where a neighbouring sample is NaN (tracker dropout) the last valid value before the
/// time is held (the first valid value before any); an all-NaN column stays NaN. Times outside
/// the trial hold its first / last values. Metadata and names are kept. Throws
/// std::invalid_argument on an empty trial or decreasing times.
Trial ResampleTrial(const Trial& trial, const std::vector<double>& times);

}  // namespace fesim
