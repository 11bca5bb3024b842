#include "posekit/body/bvh_retarget.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <tuple>

#include "posekit/core/error.h"

namespace posekit {
namespace {

enum Side { kNoSide, kLeftSide, kRightSide };

struct JointName {
  Side side = kNoSide;
  std::string base;  ///< lower case, without namespace, separators and side: "hand", "upleg", "handindex1"
};

/// "mixamorig:LeftHand" -> (left, "hand"); "L_Wrist" -> (left, "wrist"); "lhumerus" -> (left, "humerus").
JointName parse_name(const std::string& raw) {
  std::string name = raw.substr(raw.find_last_of(':') == std::string::npos ? 0 : raw.find_last_of(':') + 1);
  // Tokens at separators and lower-to-upper case changes: "LeftUpLeg" -> left, up, leg.
  std::vector<std::string> tokens;
  std::string current;
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    const bool separator = c == '_' || c == '.' || c == ' ' || c == '-';
    const bool camel = i > 0 && std::isupper(static_cast<unsigned char>(c)) && std::islower(static_cast<unsigned char>(name[i - 1]));
    if ((separator || camel) && !current.empty()) tokens.push_back(current), current.clear();
    if (!separator) current += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  if (!current.empty()) tokens.push_back(current);
  JointName out;
  std::string base;
  for (const auto& t : tokens) {
    if (t == "left" || t == "l") out.side = kLeftSide;
    else if (t == "right" || t == "r") out.side = kRightSide;
    else base += t;
  }
  // A one-letter side glued to a body word: "lhand", "rfoot", "lhumerus".
  static const char* const kWords[] = {"hand",  "wrist", "foot",     "ankle",    "humerus", "radius",  "femur", "tibia",
                                       "hip",   "knee",  "elbow",    "shoulder", "arm",     "forearm", "leg",   "upleg",
                                       "thigh", "shin",  "clavicle", "collar",   "toe",     "toes"};
  if (out.side == kNoSide && base.size() > 1 && (base[0] == 'l' || base[0] == 'r'))
    for (const char* w : kWords)
      if (base.compare(1, std::string::npos, w) == 0) {
        out.side = base[0] == 'l' ? kLeftSide : kRightSide;
        base.erase(0, 1);
        break;
      }
  out.base = base;
  return out;
}

int depth_of(const BvhMotion& m, int j) {
  int d = 0;
  for (; m.joints[static_cast<size_t>(j)].parent >= 0; j = m.joints[static_cast<size_t>(j)].parent) ++d;
  return d;
}

/// The joint nearest the root with this side and one of these base names, or -1.
int find_named(const BvhMotion& m, const std::vector<JointName>& names, Side side, const std::vector<std::string>& bases) {
  int best = -1;
  for (size_t j = 0; j < names.size(); ++j) {
    if (names[j].side != side || std::find(bases.begin(), bases.end(), names[j].base) == bases.end()) continue;
    if (best < 0 || depth_of(m, static_cast<int>(j)) < depth_of(m, best)) best = static_cast<int>(j);
  }
  return best;
}

std::vector<int> path_from_root(const BvhMotion& m, int j) {
  std::vector<int> path;
  for (; j >= 0; j = m.joints[static_cast<size_t>(j)].parent) path.push_back(j);
  std::reverse(path.begin(), path.end());
  return path;
}

/// Joint origins of the zero-rotation skeleton (the file's rest), #joints x 3.
Eigen::MatrixXd rest_positions(const BvhMotion& m) {
  Eigen::MatrixXd P(static_cast<Eigen::Index>(m.joints.size()), 3);
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const int parent = m.joints[j].parent;
    const Eigen::Vector3d base = parent < 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(P.row(parent).transpose());
    P.row(static_cast<Eigen::Index>(j)) = (base + m.joints[j].offset).transpose();
  }
  return P;
}

/// World rotation of every joint at a frame (the product of local rotations from the root).
std::vector<Eigen::Matrix3d> world_rotations(const BvhMotion& m, int frame) {
  std::vector<Eigen::Matrix3d> G(m.joints.size());
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const Eigen::Matrix3d local = m.local_rotation(frame, static_cast<int>(j));
    G[j] = m.joints[j].parent < 0 ? local : Eigen::Matrix3d(G[static_cast<size_t>(m.joints[j].parent)] * local);
  }
  return G;
}

/// The file's axes in posekit's (rows: left, up, forward) from its rest skeleton.
Eigen::Matrix3d file_to_posekit(const BvhMotion& m, const BvhPartMap& map, const Eigen::MatrixXd& P0) {
  const Eigen::Vector3d up = (P0.row(map.joint[kHead]) - P0.row(map.joint[kPelvis])).transpose().normalized();
  Eigen::Vector3d left = (P0.row(map.joint[kLeftThigh]) - P0.row(map.joint[kRightThigh])).transpose();
  left = (left - left.dot(up) * up).normalized();
  Eigen::Matrix3d W;
  W.row(0) = left.transpose();
  W.row(1) = up.transpose();
  W.row(2) = left.cross(up).transpose();
  return W;
}

double leg_length(const Eigen::MatrixXd& P, int hip, int knee, int ankle) {
  return (P.row(knee) - P.row(hip)).norm() + (P.row(ankle) - P.row(knee)).norm();
}

}  // namespace

BvhPartMap map_bvh_skeleton(const BvhMotion& m, const std::map<std::string, std::string>& overrides) {
  if (m.joints.empty()) throw InvalidInput("BVH retargeting: the motion has no joints");
  BvhPartMap map;
  std::vector<JointName> names;
  for (const auto& j : m.joints) names.push_back(parse_name(j.name));
  auto parent = [&](int j) { return j < 0 ? -1 : m.joints[static_cast<size_t>(j)].parent; };
  // Limbs from their ends: the end by name, the middle and start as its parents.
  for (const auto& [side, hand, forearm, upper, foot, shank, thigh] :
       {std::tuple{kLeftSide, kLeftHand, kLeftForearm, kLeftUpperArm, kLeftFoot, kLeftShank, kLeftThigh},
        std::tuple{kRightSide, kRightHand, kRightForearm, kRightUpperArm, kRightFoot, kRightShank, kRightThigh}}) {
    map.joint[hand] = find_named(m, names, side, {"hand", "wrist"});
    map.joint[forearm] = parent(map.joint[hand]);
    map.joint[upper] = parent(map.joint[forearm]);
    map.joint[foot] = find_named(m, names, side, {"foot", "ankle"});
    map.joint[shank] = parent(map.joint[foot]);
    map.joint[thigh] = parent(map.joint[shank]);
  }
  map.joint[kPelvis] = 0;
  map.joint[kHead] = find_named(m, names, kNoSide, {"head"});
  // Our part/joint names in overrides: "left_shoulder" is the joint that starts the left upper arm.
  auto part_of = [](const std::string& key) {
    for (int p = 0; p < kNumParts; ++p)
      if (part_name(p) == key) return p;
    const int j = find_joint_index(key);
    return j >= 0 ? j + 1 : -1;
  };
  std::array<bool, kNumParts> overridden;
  overridden.fill(false);
  for (const auto& [key, joint] : overrides) {
    const int p = part_of(key);
    if (p < 0)
      throw InvalidInput("joint map: '" + key + "' is neither a part (pelvis, ..., right_foot) nor a joint (lower_back, ..., right_ankle)");
    const int j = m.find_joint(joint);
    if (j < 0) throw InvalidInput("joint map: the BVH has no joint '" + joint + "' (for " + key + ")");
    map.joint[p] = j;
    overridden[p] = true;
  }
  // Limb joints not named in the map follow from the ones that are.
  for (const auto& [hand, forearm, upper] :
       {std::tuple{kLeftHand, kLeftForearm, kLeftUpperArm}, std::tuple{kRightHand, kRightForearm, kRightUpperArm},
        std::tuple{kLeftFoot, kLeftShank, kLeftThigh}, std::tuple{kRightFoot, kRightShank, kRightThigh}}) {
    if (!overridden[forearm] && overridden[hand]) map.joint[forearm] = parent(map.joint[hand]);
    if (!overridden[upper] && (overridden[hand] || overridden[forearm])) map.joint[upper] = parent(map.joint[forearm]);
  }
  // The spine, from the root to the head: the neck at the first neck joint above where the arms
  // branch off, the chest where they branch, the abdomen the first joint above the root.
  if (map.joint[kHead] >= 0) {
    std::vector<int> chain = path_from_root(m, map.joint[kHead]);
    chain.erase(chain.begin());  // the root
    chain.pop_back();            // the head
    int branch = -1;             // the deepest spine joint that both upper arms descend from
    if (map.joint[kLeftUpperArm] >= 0 && map.joint[kRightUpperArm] >= 0) {
      const auto a = path_from_root(m, map.joint[kLeftUpperArm]), b = path_from_root(m, map.joint[kRightUpperArm]);
      for (size_t k = 0; k < std::min(a.size(), b.size()) && a[k] == b[k]; ++k)
        if (std::find(chain.begin(), chain.end(), a[k]) != chain.end()) branch = a[k];
    }
    const auto at = [&](int j) { return static_cast<long>(std::find(chain.begin(), chain.end(), j) - chain.begin()); };
    int neck = -1;
    for (int j : chain)
      if (names[static_cast<size_t>(j)].base.find("neck") != std::string::npos && (branch < 0 || at(j) > at(branch))) {
        neck = j;
        break;
      }
    if (neck < 0 && !chain.empty() && chain.back() != branch) neck = chain.back();
    if (neck >= 0 && !overridden[kHead]) {
      // Our head part starts at the neck joint.
      map.notes.push_back("head part from " + m.joints[static_cast<size_t>(neck)].name + " (the neck), its top at " +
                          m.joints[static_cast<size_t>(map.joint[kHead])].name);
      map.head_top = map.joint[kHead];
      map.joint[kHead] = neck;
    }
    const long before_neck = neck >= 0 ? at(neck) : static_cast<long>(chain.size());
    if (!overridden[kChest]) {
      if (branch >= 0 && at(branch) < before_neck && at(branch) > 0) map.joint[kChest] = branch;
      else if (before_neck >= 2) map.joint[kChest] = chain[static_cast<size_t>(2 * before_neck / 3)];
    }
    if (!overridden[kAbdomen] && !chain.empty() && map.joint[kChest] >= 0 && at(map.joint[kChest]) > 0) map.joint[kAbdomen] = chain[0];
  }
  // Every limb part and the head are needed; a missing spine joint only stiffens the torso.
  std::string missing;
  for (int p = 0; p < kNumParts; ++p)
    if (map.joint[p] < 0 && p != kAbdomen && p != kChest) missing += (missing.empty() ? "" : ", ") + part_name(p);
  if (!missing.empty()) {
    std::string joints;
    for (size_t j = 0; j < m.joints.size() && j < 40; ++j) joints += (j ? ", " : "") + m.joints[j].name;
    throw InvalidInput("BVH retargeting: no joint found for " + missing + " among the file's joints (" + joints +
                       (m.joints.size() > 40 ? ", ..." : "") +
                       "); name them in a joint map, e.g. --joint-map map.json with {\"left_shoulder\": \"<the joint that starts the "
                       "left upper arm>\", \"left_hip\": ...}");
  }
  for (int p = 0; p < kNumParts; ++p)
    if (map.joint[p] < 0) map.notes.push_back(part_name(p) + ": no joint in the file; it moves with its parent");
  // Left is left: the left thigh's joint lies on the same side as the left upper arm's.
  const Eigen::MatrixXd P0 = rest_positions(m);
  const Eigen::Vector3d hips = (P0.row(map.joint[kLeftThigh]) - P0.row(map.joint[kRightThigh])).transpose();
  const Eigen::Vector3d shoulders = (P0.row(map.joint[kLeftUpperArm]) - P0.row(map.joint[kRightUpperArm])).transpose();
  if (hips.norm() < 1e-9 || shoulders.norm() < 1e-9 || hips.dot(shoulders) <= 0)
    throw InvalidInput(
        "BVH retargeting: the left hip and left shoulder joints (" + m.joints[static_cast<size_t>(map.joint[kLeftThigh])].name + ", " +
        m.joints[static_cast<size_t>(map.joint[kLeftUpperArm])].name + ") are not on the same side of the rest skeleton: give a joint map");
  return map;
}

std::vector<PartPose> retarget_bvh(const BvhMotion& m, const BvhPartMap& map, const Eigen::MatrixXd& rest_joints,
                                   const RetargetOptions& o) {
  if (rest_joints.rows() != kNumJoints || rest_joints.cols() != 3)
    throw InvalidInput("BVH retargeting: expected the body's 15 rest joint centres");
  const int last = o.last < 0 ? m.num_frames() : o.last;
  if (o.first < 0 || last > m.num_frames() || o.first >= last)
    throw InvalidInput("BVH retargeting: frames " + std::to_string(o.first) + " to " + std::to_string(last) + " are outside the motion's " +
                       std::to_string(m.num_frames()));
  const Eigen::MatrixXd P0 = rest_positions(m);
  const Eigen::Matrix3d W = file_to_posekit(m, map, P0);
  // Each part's rest direction (towards its child joint) turned onto the file's: A[p].
  auto ours = [&](int p) { return Eigen::Vector3d(rest_joints.row(p - 1).transpose()); };
  auto file_origin = [&](int p) { return Eigen::Vector3d(W * P0.row(map.joint[p]).transpose()); };
  std::array<Eigen::Matrix3d, kNumParts> A;
  A.fill(Eigen::Matrix3d::Identity());
  const std::pair<int, int> bones[] = {{kAbdomen, kChest},
                                       {kChest, kHead},
                                       {kLeftUpperArm, kLeftForearm},
                                       {kLeftForearm, kLeftHand},
                                       {kRightUpperArm, kRightForearm},
                                       {kRightForearm, kRightHand},
                                       {kLeftThigh, kLeftShank},
                                       {kLeftShank, kLeftFoot},
                                       {kRightThigh, kRightShank},
                                       {kRightShank, kRightFoot}};
  for (int p = 1; p < kNumParts; ++p) A[p] = A[part_parent(p)];  // leaves follow their parent's alignment
  for (const auto& [p, child] : bones) {
    if (map.joint[p] < 0 || map.joint[child] < 0) continue;
    const Eigen::Vector3d d_ours = ours(child) - ours(p), d_file = file_origin(child) - file_origin(p);
    if (d_ours.norm() < 1e-9 || d_file.norm() < 1e-9) continue;
    A[p] = Eigen::Quaterniond::FromTwoVectors(d_ours, d_file).toRotationMatrix();
  }
  for (int p : {kLeftHand, kRightHand, kLeftFoot, kRightFoot}) A[p] = A[part_parent(p)];
  // The head stands up from the neck in our rest; in the file, from the neck joint to the head's.
  if (map.head_top >= 0 && map.head_top != map.joint[kHead]) {
    const Eigen::Vector3d d_file = W * (P0.row(map.head_top) - P0.row(map.joint[kHead])).transpose();
    if (d_file.norm() > 1e-9) A[kHead] = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitY(), d_file).toRotationMatrix();
  }
  const double scale = leg_length(rest_joints, kLeftThigh - 1, kLeftShank - 1, kLeftFoot - 1) /
                       std::max(1e-12, leg_length(P0, map.joint[kLeftThigh], map.joint[kLeftShank], map.joint[kLeftFoot]));
  // The file's floor: its lowest ankle over the frames retargeted (in our axes, scaled).
  const int left_ankle = map.joint[kLeftFoot], right_ankle = map.joint[kRightFoot];
  double floor = std::numeric_limits<double>::infinity();
  std::vector<Eigen::MatrixXd> positions;
  for (int f = o.first; f < last; ++f) {
    positions.push_back(m.joint_positions(f));
    const Eigen::MatrixXd& P = positions.back();
    floor = std::min(floor, scale * std::min((W * P.row(left_ankle).transpose()).y(), (W * P.row(right_ankle).transpose()).y()));
  }
  const double rest_ankles = std::min(rest_joints(kLeftFoot - 1, 1), rest_joints(kRightFoot - 1, 1));
  const Eigen::Vector3d centre =
      (rest_joints.row(kAbdomen - 1) + rest_joints.row(kLeftThigh - 1) + rest_joints.row(kRightThigh - 1)).transpose() / 3;
  std::vector<PartPose> poses;
  Eigen::Vector3d root0 = Eigen::Vector3d::Zero();
  for (int f = o.first; f < last; ++f) {
    const std::vector<Eigen::Matrix3d> G = world_rotations(m, f);
    std::array<Eigen::Matrix3d, kNumParts> D;
    for (int p = 0; p < kNumParts; ++p) {
      const int j = map.joint[p];
      D[p] = j < 0 ? D[part_parent(p)] : Eigen::Matrix3d(W * G[static_cast<size_t>(j)] * W.transpose() * A[p]);
    }
    PartPose pose;
    pose.root_rotation = Eigen::AngleAxisd(D[kPelvis]).angle() * Eigen::AngleAxisd(D[kPelvis]).axis();
    for (int p = 1; p < kNumParts; ++p) {
      const Eigen::AngleAxisd r(Eigen::Matrix3d(D[part_parent(p)].transpose() * D[p]));
      pose.joint(p - 1) = r.angle() * r.axis();
    }
    // Our joints in this pose with the pelvis in place (forward kinematics, pelvis about its centre).
    Eigen::MatrixXd X(kNumJoints, 3);
    for (int p = 1; p < kNumParts; ++p) {
      const int parent = part_parent(p);
      const Eigen::Vector3d x = rest_joints.row(p - 1).transpose();
      const Eigen::Vector3d origin = parent == kPelvis ? centre : Eigen::Vector3d(rest_joints.row(parent - 1).transpose());
      const Eigen::Vector3d base = parent == kPelvis ? centre : Eigen::Vector3d(X.row(parent - 1).transpose());
      X.row(p - 1) = (base + D[parent] * (x - origin)).transpose();
    }
    const Eigen::MatrixXd& P = positions[static_cast<size_t>(f - o.first)];
    const Eigen::Vector3d root = W * P.row(map.joint[kPelvis]).transpose();
    if (f == o.first) root0 = root;
    Eigen::Vector3d t = Eigen::Vector3d::Zero();
    if (o.root_motion != RetargetOptions::RootMotion::kNone) {
      // Height: the lower ankle as high above our floor as the file's is above its own.
      const double file_ankles = scale * std::min((W * P.row(left_ankle).transpose()).y(), (W * P.row(right_ankle).transpose()).y());
      t.y() = rest_ankles + (file_ankles - floor) - std::min(X(kLeftFoot - 1, 1), X(kRightFoot - 1, 1));
      if (o.root_motion == RetargetOptions::RootMotion::kAll) t.x() = scale * (root - root0).x(), t.z() = scale * (root - root0).z();
    }
    pose.root_translation = t;
    poses.push_back(pose);
  }
  return poses;
}

Eigen::MatrixXd bvh_joints_in_body_frame(const BvhMotion& m, const BvhPartMap& map, const Eigen::MatrixXd& rest_joints, int frame) {
  const Eigen::MatrixXd P0 = rest_positions(m);
  const Eigen::Matrix3d W = file_to_posekit(m, map, P0);
  const double scale = leg_length(rest_joints, kLeftThigh - 1, kLeftShank - 1, kLeftFoot - 1) /
                       std::max(1e-12, leg_length(P0, map.joint[kLeftThigh], map.joint[kLeftShank], map.joint[kLeftFoot]));
  const Eigen::MatrixXd P = m.joint_positions(frame);
  Eigen::MatrixXd out(P.rows(), 3);
  for (Eigen::Index j = 0; j < P.rows(); ++j) out.row(j) = (scale * W * (P.row(j) - P0.row(map.joint[kPelvis])).transpose()).transpose();
  return out;
}

}  // namespace posekit
