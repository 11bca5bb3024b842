#pragma once
// The MakeHuman body model read from the CC0 assets: base mesh, morph targets, macro sliders,
// local modifiers, the 163-bone rig and its skinning weights. Loaded once, then bodies are cheap.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <string>
#include <vector>

#include "posekit/body/body_spec.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// A morph target: sparse vertex offsets (m) into the full base mesh.
struct MorphTarget {
  std::vector<int> index;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> delta;
};

/// The 163-bone skeleton. Bones are in topological order (parents first).
struct Rig {
  std::vector<std::string> bone_names;
  std::vector<int> parent;                      ///< -1 for the root
  std::vector<std::vector<int>> head_vertices;  ///< base-mesh vertices whose mean is the head
  std::vector<std::vector<int>> tail_vertices;
  /// Three joints (as vertex lists) spanning the plane that fixes each bone's roll; empty if none.
  std::vector<std::vector<std::vector<int>>> plane_vertices;
  int find_bone(const std::string& name) const;  ///< -1 when absent
  int num_bones() const { return static_cast<int>(bone_names.size()); }
};

struct MakeHumanModel {
  std::string data_root;
  Eigen::MatrixXd base_V;     ///< all base.obj vertices (skin and helpers), m
  Eigen::MatrixXi body_F;     ///< skin triangles (group `body`), indices < num_body_vertices
  int num_body_vertices = 0;  ///< 13,380: the skin vertices are the first ones of base.obj
  struct MacroTarget {
    std::string name;                   ///< file path under targets/, e.g. macrodetails/height/...
    std::vector<std::string> variants;  ///< e.g. {"female","young","maxmuscle","averageweight"}
    MorphTarget target;
  };
  std::vector<MacroTarget> macro_targets;
  struct Modifier {
    std::string name;                  ///< "group/target-min|max" or "group/target"
    int negative = -1, positive = -1;  ///< indices into modifier_targets (-1: none)
    bool two_sided = false;
  };
  std::vector<Modifier> modifiers;
  std::vector<MorphTarget> modifier_targets;
  Rig rig;
  /// Skinning weights of the skin vertices, #body vertices x #bones, rows sum to 1.
  Eigen::SparseMatrix<double, Eigen::RowMajor> weights;

  const Modifier* find_modifier(const std::string& name) const;
};

/// What load_makehuman_model reads: everything, or the skin alone (base mesh, rig and skinning
/// weights, no targets: enough to pose a shape space's bodies, in a tenth of the time).
enum class MakeHumanParts { kAll, kSkin };

/// Loads a MakeHuman data root (see find_data_root). Throws IoError naming the missing or malformed
/// file.
std::shared_ptr<const MakeHumanModel> load_makehuman_model(const std::string& data_root, MakeHumanParts parts = MakeHumanParts::kAll);

/// A shaped body: the skin mesh and the rig's joint positions for that shape.
struct Body {
  TriangleMesh mesh;           ///< skin only, #V = 13,380, metres, rest A-pose
  Eigen::MatrixXd bone_heads;  ///< #bones x 3, m (means of the helper vertex groups)
  Eigen::MatrixXd bone_tails;  ///< #bones x 3, m
  /// Rest frame of each bone: columns X, Y (head to tail), Z; Z is the normal of the bone's
  /// rotation plane, so local (bone-space) rotations such as pose units have a fixed meaning.
  std::vector<Eigen::Matrix3d> bone_frames;
};

/// Macro weights of one target's variants for a spec (the product rule of the MakeHuman README).
double macro_target_weight(const std::vector<std::string>& variants, const BodySpec& spec);

/// All base.obj vertices (skin and helpers, #base x 3, m) shaped by the spec: macro targets, then
/// local modifiers. Throws InvalidInput for an unknown modifier or out-of-range value.
Eigen::MatrixXd shaped_base_vertices(const MakeHumanModel& model, const BodySpec& spec);

/// Shapes the base mesh by the spec: macro targets, then local modifiers; recomputes the joints.
/// Throws InvalidInput for an unknown modifier or out-of-range value.
Body build_body(const MakeHumanModel& model, const BodySpec& spec);

}  // namespace posekit
