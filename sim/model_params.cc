#include "sim/model_params.h"

#include <algorithm>
#include <stdexcept>

namespace fesim::sim {

const std::array<std::string, kNumCoordinates>& CoordinateNames() {
  static const std::array<std::string, kNumCoordinates> names = {"shoulder_elv_plane",
                                                                 "shoulder_elevation",
                                                                 "shoulder_rotation",
                                                                 "elbow_flexion",
                                                                 "pro_sup",
                                                                 "wrist_flexion",
                                                                 "wrist_deviation",
                                                                 "mcp_flexion",
                                                                 "pip_flexion",
                                                                 "dip_flexion"};
  return names;
}

int CoordinateIndex(const std::string& name) {
  const auto& n = CoordinateNames();
  for (int i = 0; i < kNumCoordinates; ++i) {
    if (n[i] == name) return i;
  }
  return -1;
}

const std::array<std::string, kNumSegments>& SegmentNames() {
  static const std::array<std::string, kNumSegments> names = {
      "humerus", "forearm", "hand", "proximal_phalanx", "middle_phalanx", "distal_phalanx"};
  return names;
}

int SegmentIndex(const std::string& name) {
  const auto& n = SegmentNames();
  for (int i = 0; i < kNumSegments; ++i) {
    if (n[i] == name) return i;
  }
  return -1;
}

double TrialGenerationTolerance(const ModelParams& model) {
  for (const CoordinateParams& c : model.coordinates) {
    if (c.mode == CoordinateMode::kFree &&
        (c.passive.coulomb_friction_nm > 0.0 || c.passive.static_friction_nm > 0.0)) {
      return TaskTolerances::kTrialGenerationFriction;
    }
  }
  if (model.mechanisms.tremor.enabled) return TaskTolerances::kTrialGenerationTremor;
  return TaskTolerances::kTrialGeneration;
}

muscles::ArrayMatrix BuildElectrodeMatrix(const ModelParams& model) {
  const int nm = static_cast<int>(model.muscles.size());
  const int nc = static_cast<int>(model.channels.size());
  const auto muscle_index = [&](const std::string& name) {
    for (int j = 0; j < nm; ++j) {
      if (model.muscles[j].name == name) return j;
    }
    throw std::invalid_argument("electrodes: unknown muscle '" + name + "'");
  };
  // Geometry part: each channel's current is split equally among its pads.
  muscles::ArrayGeometry g;
  g.pads =
      muscles::PadGrid(model.array.rows, model.array.cols, model.array.pitch_m, model.array.origin);
  g.spread_m = model.array.spread_m;
  for (const auto& c : model.channels) g.channel_pads.push_back(c.pads);
  std::vector<int> reached;  // muscle index of each motor point
  for (const auto& [name, point] : model.array.motor_points) {
    reached.push_back(muscle_index(name));
    g.motor_points.push_back(point);
  }
  const muscles::ArrayMatrix geometric = muscles::ArrayFromGeometry(g);
  // Crosstalk (mechanisms.h): a wider second spread on the array.
  const CrosstalkParams& xt = model.mechanisms.crosstalk;
  muscles::ArrayGeometry gx = g;
  gx.spread_m = xt.spread_m;
  const muscles::ArrayMatrix wide = muscles::ArrayFromGeometry(gx);
  muscles::ArrayMatrix a;
  a.muscles = nm;
  a.channels = nc;
  a.a.assign(static_cast<std::size_t>(nm) * nc, 0.0);
  for (int k = 0; k < nc; ++k) {
    const double share = model.channels[k].pads.empty() ? 0.0 : 1.0 / model.channels[k].pads.size();
    for (std::size_t p = 0; p < reached.size(); ++p) {
      const int ip = static_cast<int>(p);
      a.a[static_cast<std::size_t>(reached[p]) * nc + k] +=
          share * (geometric(ip, k) + xt.fraction * wide(ip, k));
    }
    std::vector<int> driven;
    for (const auto& [name, w] : model.channels[k].muscle_weights) {
      a.a[static_cast<std::size_t>(muscle_index(name)) * nc + k] += w;
      driven.push_back(muscle_index(name));
    }
    // Crosstalk of an electrode pair: fraction c of its largest weight to every other muscle
    // that crosses a joint the driven muscles cross.
    if (xt.fraction > 0.0 && !driven.empty()) {
      double w_max = 0.0;
      for (const auto& mw : model.channels[k].muscle_weights) w_max = std::max(w_max, mw.second);
      for (int j = 0; j < nm; ++j) {
        if (std::find(driven.begin(), driven.end(), j) != driven.end()) continue;
        bool shares = false;
        for (int d : driven) {
          for (const auto& cj : model.muscles[j].path.crossings) {
            for (const auto& cd : model.muscles[d].path.crossings) shares |= cj.joint == cd.joint;
          }
        }
        if (shares) a.a[static_cast<std::size_t>(j) * nc + k] += xt.fraction * w_max;
      }
    }
  }
  return a;
}

}  // namespace fesim::sim
