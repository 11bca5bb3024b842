#include "posekit/population/template_anthropometry.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <map>
#include <set>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/shape/measurements.h"

namespace posekit {
namespace {

struct EdgeCut {
  int a, b;
  double t;
  Eigen::Vector3d p;
};

/// Every mesh edge the plane {normal . x = offset} crosses, with the crossing's fraction along it.
std::vector<EdgeCut> plane_cuts(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& normal, double offset) {
  std::vector<EdgeCut> cuts;
  std::set<std::pair<int, int>> seen;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      const double sa = normal.dot(V.row(a).transpose()) - offset, sb = normal.dot(V.row(b).transpose()) - offset;
      if ((sa < 0) == (sb < 0) || !seen.insert({std::min(a, b), std::max(a, b)}).second) continue;
      const double t = sa / (sa - sb);
      cuts.push_back({a, b, t, (V.row(a) + t * (V.row(b) - V.row(a))).transpose()});
    }
  return cuts;
}

class Builder {
 public:
  explicit Builder(TemplateAnthropometry* out) : out_(out) {}
  int local(int base_index) {
    const auto [it, inserted] = rows_.emplace(base_index, static_cast<int>(out_->vertices.size()));
    if (inserted) out_->vertices.push_back(base_index);
    return it->second;
  }
  std::vector<int> local(const std::vector<int>& base_indices) {
    std::vector<int> r;
    for (int i : base_indices) r.push_back(local(i));
    return r;
  }

 private:
  TemplateAnthropometry* out_;
  std::map<int, int> rows_;
};

enum class LoopChoice { kLargest, kNearest };

/// The tape loop of the template's section by the plane through `point` with `normal`.
TapeLoop make_loop(Builder& builder, const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& point,
                   const Eigen::Vector3d& normal, LoopChoice choice, const char* what) {
  const double offset = normal.dot(point);
  const std::vector<SectionLoop> loops = slice_mesh(V, F, normal, offset);
  int chosen = -1;
  if (choice == LoopChoice::kNearest) {
    chosen = nearest_loop(loops, point);
  } else {
    double longest = 0;
    for (size_t i = 0; i < loops.size(); ++i) {
      const double length = polyline_length(loops[i].points, loops[i].closed);
      if (loops[i].closed && length > longest) longest = length, chosen = static_cast<int>(i);
    }
  }
  if (chosen < 0 || !loops[chosen].closed || loops[chosen].points.rows() < 8)
    throw InvalidInput(std::string("template anthropometry: no closed section for the ") + what);
  const std::vector<EdgeCut> cuts = plane_cuts(V, F, normal, offset);
  TapeLoop loop;
  loop.horizontal = std::abs(normal.normalized().y()) > 0.999;
  std::set<size_t> used;
  const Eigen::MatrixXd& P = loops[chosen].points;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    size_t best = cuts.size();
    double best_d = 1e-6;
    for (size_t c = 0; c < cuts.size(); ++c) {
      const double d = (cuts[c].p - P.row(i).transpose()).norm();
      if (d < best_d) best_d = d, best = c;
    }
    if (best == cuts.size() || !used.insert(best).second) continue;  // a cut through a vertex
    loop.a.push_back(builder.local(cuts[best].a));
    loop.b.push_back(builder.local(cuts[best].b));
    loop.t.push_back(cuts[best].t);
  }
  if (loop.t.size() < 8) throw InvalidInput(std::string("template anthropometry: the ") + what + " section has too few edge cuts");
  return loop;
}

Eigen::Vector3d mean_of(const Eigen::MatrixXd& V, const std::vector<int>& rows) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (int r : rows) m += V.row(r).transpose();
  return m / static_cast<double>(std::max<size_t>(1, rows.size()));
}

const Girth& girth(const BodyMeasurements& m, const char* name) {
  const Girth* g = m.find(name);
  if (!g || !g->measured) throw InvalidInput(std::string("template anthropometry: the template's ") + name + " girth is not measured");
  return *g;
}

std::vector<int> rig_joint(const MakeHumanModel& model, const char* bone) {
  const int b = model.rig.find_bone(bone);
  if (b < 0) throw InvalidInput(std::string("template anthropometry: the rig has no bone '") + bone + "'");
  return model.rig.head_vertices[b];
}

/// The acromion: where the shoulder's top turns into the arm, the skin in the shoulder joint's
/// frontal plane whose normal points 45 degrees up and outward.
int acromion_vertex(const MakeHumanModel& model, const Eigen::MatrixXd& base, const Eigen::MatrixXd& V, const Eigen::MatrixXd& N,
                    const char* const shoulders[2], int side) {
  const Eigen::Vector3d shoulder = mean_of(base, rig_joint(model, shoulders[side]));
  const Eigen::Vector3d other = mean_of(base, rig_joint(model, shoulders[1 - side]));
  const Eigen::Vector3d outward_up = Eigen::Vector3d(shoulder.x() > other.x() ? 1.0 : -1.0, 1.0, 0.0).normalized();
  int best = -1;
  double best_cos = -1;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (std::abs(V(i, 2) - shoulder.z()) > 0.015 || V(i, 1) < shoulder.y()) continue;
    const double c = N.row(i).dot(outward_up.transpose());
    if (c > best_cos) best_cos = c, best = static_cast<int>(i);
  }
  if (best < 0) throw InvalidInput(std::string("template anthropometry: no skin above the shoulder joint ") + shoulders[side]);
  return best;
}

}  // namespace

TemplateAnthropometry make_template_anthropometry(const MakeHumanModel& model, const BodySpec& spec) {
  const Eigen::MatrixXd base = shaped_base_vertices(model, spec);
  const Eigen::MatrixXd V = base.topRows(model.num_body_vertices);
  const Eigen::MatrixXi& F = model.body_F;
  const BodyMeasurements m = measure_body(V, F);
  const Eigen::MatrixXd N = vertex_normals(V, F);
  TemplateAnthropometry a;
  Builder builder(&a);

  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  auto horizontal_at = [&](const Girth& g) { return g.point; };
  a.loops[0] = make_loop(builder, V, F, horizontal_at(girth(m, "bust")), up, LoopChoice::kLargest, "chest");
  // The waist at the navel: the centroid of what MakeHuman's navel target moves, weighted by how far.
  const auto* navel = model.find_modifier("stomach/stomach-navel-in|out");
  if (!navel || navel->positive < 0) throw InvalidInput("template anthropometry: the data root has no stomach-navel-in|out target");
  const MorphTarget& navel_target = model.modifier_targets[navel->positive];
  Eigen::Vector3d navel_point = Eigen::Vector3d::Zero();
  double total = 0;
  for (size_t i = 0; i < navel_target.index.size(); ++i) {
    const double w = navel_target.delta.row(static_cast<Eigen::Index>(i)).norm();
    navel_point += w * base.row(navel_target.index[i]).transpose();
    total += w;
  }
  navel_point /= total;
  a.loops[1] = make_loop(builder, V, F, navel_point, up, LoopChoice::kLargest, "waist (navel)");
  a.loops[2] = make_loop(builder, V, F, girth(m, "hip").point, up, LoopChoice::kLargest, "buttock");
  for (const auto& [index, name] : std::vector<std::pair<int, const char*>>{{3, "thigh"}, {4, "calf"}, {5, "neck"}, {6, "upper_arm"}}) {
    const Girth& g = girth(m, name);
    a.loops[index] = make_loop(builder, V, F, g.point, g.normal, LoopChoice::kNearest, name);
  }

  const double top = V.col(1).maxCoeff(), bottom = V.col(1).minCoeff();
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (V(i, 1) > top - 0.01) a.crown.push_back(builder.local(static_cast<int>(i)));
    if (V(i, 1) < bottom + 0.005) a.soles.push_back(builder.local(static_cast<int>(i)));
  }
  Eigen::Index crotch = 0;
  const Eigen::Vector3d crotch_point(m.features.axis_x, m.features.crotch_y, m.features.crotch_axis_z);
  (V.rowwise() - crotch_point.transpose()).rowwise().squaredNorm().minCoeff(&crotch);
  a.crotch = builder.local(static_cast<int>(crotch));
  const char* shoulders[2] = {"upperarm01.L", "upperarm01.R"};
  const char* elbows[2] = {"lowerarm01.L", "lowerarm01.R"};
  const char* wrists[2] = {"wrist.L", "wrist.R"};
  for (int side = 0; side < 2; ++side) {
    const int best = acromion_vertex(model, base, V, N, shoulders, side);
    a.acromion[side] = builder.local(best);
    a.elbow[side] = builder.local(rig_joint(model, elbows[side]));
    a.wrist[side] = builder.local(rig_joint(model, wrists[side]));
  }
  return a;
}

Eigen::MatrixXd gather_measured_vertices(const TemplateAnthropometry& a, const Eigen::MatrixXd& base_V) {
  Eigen::MatrixXd P(a.vertices.size(), 3);
  for (size_t i = 0; i < a.vertices.size(); ++i) P.row(static_cast<Eigen::Index>(i)) = base_V.row(a.vertices[i]);
  return P;
}

SurveyValues measure_template_body(const TemplateAnthropometry& a, const Eigen::MatrixXd& P) {
  SurveyValues out{};
  for (int g = 0; g < 7; ++g) {
    const TapeLoop& loop = a.loops[g];
    Eigen::MatrixXd points(loop.t.size(), 3);
    for (size_t i = 0; i < loop.t.size(); ++i)
      points.row(static_cast<Eigen::Index>(i)) = P.row(loop.a[i]) + loop.t[i] * (P.row(loop.b[i]) - P.row(loop.a[i]));
    Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
    if (!loop.horizontal) {
      const Eigen::MatrixXd centred = points.rowwise() - points.colwise().mean();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(centred.transpose() * centred);
      normal = eig.eigenvectors().col(0);
    }
    out[1 + g] = convex_hull_perimeter(points, normal);
  }
  double crown = -1e9, sole = 1e9;
  for (int r : a.crown) crown = std::max(crown, P(r, 1));
  for (int r : a.soles) sole = std::min(sole, P(r, 1));
  out[static_cast<int>(SurveyMeasure::kStature)] = crown - sole;
  out[static_cast<int>(SurveyMeasure::kCrotchHeight)] = P(a.crotch, 1) - sole;
  out[static_cast<int>(SurveyMeasure::kAcromialHeight)] = 0.5 * (P(a.acromion[0], 1) + P(a.acromion[1], 1)) - sole;
  out[static_cast<int>(SurveyMeasure::kBiacromialBreadth)] = (P.row(a.acromion[0]) - P.row(a.acromion[1])).norm();
  double sleeve = 0;
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3d acromion = P.row(a.acromion[side]).transpose();
    const Eigen::Vector3d elbow = mean_of(P, a.elbow[side]), wrist = mean_of(P, a.wrist[side]);
    sleeve += 0.5 * ((elbow - acromion).norm() + (wrist - elbow).norm());
  }
  out[static_cast<int>(SurveyMeasure::kSleeveOutseam)] = sleeve;
  return out;
}

}  // namespace posekit
