#include "posekit/registration/registration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/parallel.h"
#include "posekit/core/plugin.h"
#include "posekit/core/timer.h"
#include "posekit/registration/correspondence.h"
#include "posekit/registration/ctffd.h"
#include "posekit/registration/nicp.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {
namespace {

/// NICP's landmarks: points of the source's representation on the source surface, to land on the
/// same points of the target's (the layered representations share one topology).
std::vector<NicpLandmark> representation_landmarks(const TriangleMesh& source, const LayeredRepresentation& rs,
                                                   const LayeredRepresentation& rt, int layer_stride, int point_stride) {
  const int n = rs.points_per_layer;
  std::vector<Eigen::Index> picked;
  for (size_t layer = 0; layer < rs.layers.size(); layer += static_cast<size_t>(std::max(layer_stride, 1)))
    for (int k = 0; k < n; k += std::max(point_stride, 1)) picked.push_back(static_cast<Eigen::Index>(layer) * n + k);
  Eigen::MatrixXd points(static_cast<Eigen::Index>(picked.size()), 3);
  for (size_t i = 0; i < picked.size(); ++i) points.row(static_cast<Eigen::Index>(i)) = rs.mesh.V.row(picked[i]);
  const ClosestPoints on_source = TriangleTree(source.V, source.F).closest(points, 1);
  std::vector<NicpLandmark> out(picked.size());
  for (size_t i = 0; i < picked.size(); ++i) {
    out[i].source_face = on_source.face[static_cast<Eigen::Index>(i)];
    out[i].source_bary = on_source.bary.row(static_cast<Eigen::Index>(i)).transpose();
    out[i].target = rt.mesh.V.row(picked[i]).transpose();
  }
  return out;
}

/// Registration compares bodies point by point: both must stand along +Y in one unit.
void require_comparable_bodies(const TriangleMesh& source, const TriangleMesh& target) {
  // The extent between the 1st and 99th percentiles of each coordinate: floating bits and loose
  // vertices beside a scanned body do not count.
  const auto extent = [](const TriangleMesh& m) {
    Eigen::RowVector3d e;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> x(m.V.col(c).data(), m.V.col(c).data() + m.V.rows());
      const size_t lo = x.size() / 100, hi = x.size() - 1 - x.size() / 100;
      std::nth_element(x.begin(), x.begin() + static_cast<long>(lo), x.end());
      const double a = x[lo];
      std::nth_element(x.begin(), x.begin() + static_cast<long>(hi), x.end());
      e[c] = x[hi] - a;
    }
    return e;
  };
  const auto text = [](const Eigen::RowVector3d& e) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.4g x %.4g x %.4g", e[0], e[1], e[2]);
    return std::string(buf);
  };
  const Eigen::RowVector3d es = extent(source), et = extent(target);
  for (const auto& [e, name] : {std::pair{es, "source"}, std::pair{et, "target"}})
    if (!(e[1] > e[0] && e[1] > e[2]))
      throw InvalidInput(std::string("registration: the ") + name + " does not stand along +Y (extent x, y, z " + text(e) +
                         " between the 1st and 99th percentiles): turn it into posekit's frame first (posekit register "
                         "detects the up and forward axes, or takes --" +
                         name + "-up/--" + name + "-forward)");
  const double ratio = et[1] / es[1];
  if (!(ratio > 0.5 && ratio < 2.0))
    throw InvalidInput("registration: the target is " + std::to_string(ratio) + " times the source's height (" + text(es) + " against " +
                       text(et) +
                       "): the two meshes are in different units; convert one "
                       "(posekit register --unit, or the file's unit)");
}

/// Limbs of the target whose length between its found joints, relative to the source's, is far from
/// the two statures' ratio: ct-FFD's layers on that limb follow wrong features.
std::vector<std::string> implausible_limbs(const BodyFeatures& source, const BodyFeatures& target) {
  std::vector<std::string> out;
  if (!(source.stature > 0) || !(target.stature > 0)) return out;
  const double scale = target.stature / source.stature;
  const auto length = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).norm(); };
  for (int side : {0, 1}) {
    const std::string s = side == 0 ? "left " : "right ";
    struct Limb {
      const char* name;
      double ratio;
      bool arm;
    };
    const Limb limbs[] = {
        {"upper arm", length(target.shoulder[side], target.elbow[side]) / length(source.shoulder[side], source.elbow[side]), true},
        {"forearm", length(target.elbow[side], target.wrist[side]) / length(source.elbow[side], source.wrist[side]), true},
        {"thigh", length(target.hip[side], target.knee[side]) / length(source.hip[side], source.knee[side]), false},
        {"shank", length(target.knee[side], target.ankle[side]) / length(source.knee[side], source.ankle[side]), false}};
    for (const Limb& limb : limbs) {
      if (limb.arm && (!target.arm_found[side] || !source.arm_found[side])) continue;
      const double relative = limb.ratio / scale;
      if (relative < 0.75 || relative > 1.3) {
        char buf[320];
        std::snprintf(buf, sizeof buf,
                      "the target's %s%s is %.2f of the source's length (scaled by stature): its joints were "
                      "found on wrong features (a hole or a cut taken for the limb's end?) and the correspondence there is "
                      "not to be trusted",
                      s.c_str(), limb.name, relative);
        out.push_back(buf);
      }
    }
  }
  return out;
}

}  // namespace

NicpOptions RegistrationOptions::refinement_defaults() {
  NicpOptions o;
  o.stiffness = {4, 2};
  o.max_iterations_per_stiffness = 2;
  o.align_landmarks_first = false;
  return o;
}

RegistrationQuality assess_registration(const TriangleMesh& source, const Eigen::MatrixXd& deformed, const TriangleMesh& target) {
  if (deformed.rows() != source.V.rows()) throw InvalidInput("assess_registration: one registered position per source vertex expected");
  RegistrationQuality q;
  const ClosestPoints to_target = TriangleTree(target.V, target.F).closest(deformed, 1);
  std::vector<double> d(to_target.distance.data(), to_target.distance.data() + to_target.distance.size());
  for (double x : d) q.mean_distance_mm += 1000 * x / static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  q.p95_distance_mm = 1000 * d[static_cast<size_t>(0.95 * static_cast<double>(d.size() - 1))];
  const ClosestPoints to_source = TriangleTree(deformed, source.F).closest(target.V, 1);
  q.target_covered = (to_source.distance.array() < 0.010).cast<double>().mean();
  const Eigen::MatrixXd ns = vertex_normals(deformed, source.F), nt = face_normals(target.V, target.F);
  int agree = 0;
  for (Eigen::Index i = 0; i < deformed.rows(); ++i) agree += ns.row(i).dot(nt.row(to_target.face[i])) > 0.5;
  q.normals_agree = static_cast<double>(agree) / static_cast<double>(deformed.rows());
  const Eigen::MatrixXd before = face_normals(source.V, source.F), after = face_normals(deformed, source.F);
  for (Eigen::Index f = 0; f < source.F.rows(); ++f) q.folded_triangles += before.row(f).dot(after.row(f)) < 0;
  char buf[256];
  if (q.mean_distance_mm > 3 || q.p95_distance_mm > 10) {
    std::snprintf(buf, sizeof buf,
                  "the registered source lies %.1f mm (p95 %.1f mm) from the target: it does not follow the "
                  "target's shape, and the correspondence is poor",
                  q.mean_distance_mm, q.p95_distance_mm);
    q.warnings.push_back(buf);
  }
  if (q.target_covered < 0.95) {
    std::snprintf(buf, sizeof buf,
                  "%.1f%% of the target is farther than 10 mm from the registered source (a part it "
                  "did not reach: another pose, or something the source does not have)",
                  100 * (1 - q.target_covered));
    q.warnings.push_back(buf);
  }
  if (q.normals_agree < 0.95) {
    std::snprintf(buf, sizeof buf,
                  "%.1f%% of the registered source faces more than 60 degrees away from the target "
                  "surface it lies on",
                  100 * (1 - q.normals_agree));
    q.warnings.push_back(buf);
  }
  if (q.folded_triangles > source.F.rows() / 1000) {
    std::snprintf(buf, sizeof buf, "%d triangles of the source folded over", q.folded_triangles);
    q.warnings.push_back(buf);
  }
  return q;
}

RegistrationMethod parse_registration_method(const std::string& name) {
  if (name == "ctffd") return RegistrationMethod::kCtffd;
  if (name == "icp") return RegistrationMethod::kIcp;
  if (name == "nicp") return RegistrationMethod::kNicp;
  throw InvalidInput("unknown registration method '" + name + "': expected ctffd, icp or nicp");
}

struct CtffdSource::Impl {
  TriangleMesh mesh;
  BodyFeatures features;
  LayeredRepresentation representation;
  CtffdParametrization parametrization;
  int points_per_layer = 0;
  double seconds = 0;
};

CtffdSource::CtffdSource(const TriangleMesh& source, int points_per_layer) {
  require_usable_mesh(source, "registration source");
  require_comparable_bodies(source, source);  // standing along +Y
  const Stopwatch t0;
  auto impl = std::make_shared<Impl>();
  impl->mesh = source;
  TriangleMesh surface;
  impl->features = find_body_features(source.V, source.F, &surface);
  impl->representation = build_layered_representation_on_surface(surface, impl->features, points_per_layer);
  impl->parametrization = ctffd_parametrize(source.V, impl->representation);
  impl->points_per_layer = points_per_layer;
  impl->seconds = t0.seconds();
  impl_ = std::move(impl);
}

const TriangleMesh& CtffdSource::mesh() const { return impl_->mesh; }
int CtffdSource::points_per_layer() const { return impl_->points_per_layer; }
double CtffdSource::seconds() const { return impl_->seconds; }
const CtffdSource::Impl& CtffdSource::impl() const { return *impl_; }

namespace {

/// The registration itself; `prepared` holds the source's side of ct-FFD (kCtffd).
/// Both meshes usable, standing along +Y in one unit: checked once per registration, by its entry point.
void check_inputs(const TriangleMesh& source, const TriangleMesh& target) {
  require_usable_mesh(source, "registration source");
  require_usable_mesh(target, "registration target");
  require_comparable_bodies(source, target);
}

/// A body's features and the surface they were found on (body_surface), which its representation is cut from.
struct FoundFeatures {
  BodyFeatures features;
  TriangleMesh surface;
};

FoundFeatures found_features(const TriangleMesh& body, int threads) {
  FoundFeatures out;
  out.features = find_body_features(body.V, body.F, &out.surface, threads);
  return out;
}

/// Inputs checked by the caller. `target_features`: the target's, when found already (beside the
/// source's side).
RegistrationResult register_with(const TriangleMesh& source, const CtffdSource::Impl* prepared, const TriangleMesh& target,
                                 const RegistrationOptions& o, const FoundFeatures* target_features = nullptr) {
  // PCL's ICP lives in the "icp" plugin, loaded before the clock starts (Table 1 times ICP, not dlopen).
  using Icp = void(const Eigen::MatrixXd&, const Eigen::MatrixXd&, int, Eigen::Matrix4d*);
  Icp* const pcl_icp = o.method == RegistrationMethod::kIcp ? plugin_function<Icp>("icp", "posekit_pcl_icp") : nullptr;
  const Stopwatch t0;
  RegistrationResult r;
  if (o.method == RegistrationMethod::kCtffd) {
    if (o.points_per_layer != prepared->points_per_layer)
      throw InvalidInput("registration: the source was prepared with " + std::to_string(prepared->points_per_layer) +
                         " points per layer, the options ask for " + std::to_string(o.points_per_layer));
    const CtffdSource::Impl& s = *prepared;
    const int threads = resolve_threads(o.threads);
    // ct-FFD (Eq. 1): the target's features and layers, the source deformed onto them.
    auto ctffd = [&] {
      const FoundFeatures found = target_features ? FoundFeatures{} : found_features(target, threads);
      const FoundFeatures& t = target_features ? *target_features : found;
      const BodyFeatures& ft = t.features;
      for (const std::string& w : s.features.warnings) r.warnings.push_back("source: " + w);
      for (const std::string& w : ft.warnings) r.warnings.push_back("target: " + w);
      for (std::string& w : implausible_limbs(s.features, ft)) r.warnings.push_back(std::move(w));
      const LayeredRepresentation rt =
          build_layered_representation_on_surface(t.surface, torso_levels_in_proportion(ft, s.features), o.points_per_layer, threads);
      r.deformed_source = ctffd_evaluate(s.parametrization, rt);
      r.ctffd_seconds = t0.seconds();
    };
    // With a second thread the shape fit's view of the target is made beside it.
    std::unique_ptr<ShapeFitTarget> fit_target;
    if (o.shape_space && threads > 1)
      run_beside(
          threads, [&] { fit_target = std::make_unique<ShapeFitTarget>(target); }, ctffd);
    else ctffd();
    if (o.shape_space) {
      if (o.shape_space->vertices() != source.V.rows())
        throw InvalidInput("registration: the shape space has " + std::to_string(o.shape_space->vertices()) + " vertices, the source " +
                           std::to_string(source.V.rows()) + ": it must be of the source's topology");
      if (o.shape_space->faces.size() > 0 && o.shape_space->faces != source.F)
        throw InvalidInput("registration: the shape space's triangles are not the source's (same " + std::to_string(source.V.rows()) +
                           " vertices, other connectivity): it must be of the source's topology");
      const Stopwatch t1;
      if (!fit_target) fit_target = std::make_unique<ShapeFitTarget>(target);
      ShapeFitOptions fit_options = o.shape_fit;
      fit_options.threads = threads;
      r.shape_fit = fit_shape_space(*o.shape_space, source.F, r.deformed_source, *fit_target, fit_options);
      r.shape_fit_seconds = t1.seconds();
      if (r.shape_fit.plausible) {
        r.deformed_source = r.shape_fit.V;
      } else {
        const ShapeFitResult& f = r.shape_fit;
        const auto share = [](double fit, double start) {
          char b[96];
          if (start >= 0) std::snprintf(b, sizeof b, "%.1f%% (ct-FFD's result: %.1f%%)", 100 * fit, 100 * start);
          else std::snprintf(b, sizeof b, "%.1f%%", 100 * fit);
          return std::string(b);
        };
        char buf[160];
        std::snprintf(buf, sizeof buf, "the shape space's best fit lies %.1f mm (median) from the target; ", 1000 * f.median_distance);
        const std::string far = std::to_string(static_cast<int>(std::lround(1000 * o.shape_fit.far_distance)));
        r.warnings.push_back(buf + share(f.far_share, f.start_far_share) + " of it over " + far + " mm away and " +
                             share(f.uncovered_share, f.start_uncovered_share) +
                             " of the target that far from it: the "
                             "target is not a body the space can say (another pose, a cut, or a shape outside its "
                             "population); ct-FFD's result is kept");
      }
    }
    if (o.refine) {
      r.nicp = nonrigid_icp(source, target, o.refinement, {}, &r.deformed_source);
      r.deformed_source = r.nicp.V;
    }
  } else if (o.method == RegistrationMethod::kNicp) {
    const FoundFeatures fs = found_features(source, 1), ft = found_features(target, 1);
    const LayeredRepresentation rs = build_layered_representation_on_surface(fs.surface, fs.features, 16);
    const LayeredRepresentation rt = build_layered_representation_on_surface(ft.surface, ft.features, 16);
    r.nicp =
        nonrigid_icp(source, target, o.nicp, representation_landmarks(source, rs, rt, o.landmark_layer_stride, o.landmark_point_stride));
    r.deformed_source = r.nicp.V;
  } else {
    if (o.icp_iterations < 1) throw InvalidInput("ICP needs at least one iteration");
    Eigen::Matrix4d T;
    pcl_icp(source.V, target.V, o.icp_iterations, &T);
    r.deformed_source = (source.V * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose();
  }
  r.correspondence = nearest_centroid_correspondence(r.deformed_source, source.F, target.V, target.F, &r.normal_failures,
                                                     o.method == RegistrationMethod::kCtffd ? o.threads : 1);
  r.seconds = t0.seconds();
  return r;
}

}  // namespace

RegistrationResult register_bodies(const TriangleMesh& source, const TriangleMesh& target, const RegistrationOptions& o) {
  check_inputs(source, target);
  if (o.method != RegistrationMethod::kCtffd) return register_with(source, nullptr, target, o);
  if (resolve_threads(o.threads) < 2) {
    const CtffdSource prepared(source, o.points_per_layer);  // timed with the rest
    RegistrationResult r = register_with(source, &prepared.impl(), target, o);
    r.seconds += prepared.seconds();
    r.ctffd_seconds += prepared.seconds();
    return r;
  }
  // The source's side on a second thread while the target's features are found; timed as a whole.
  const Stopwatch t0;
  std::unique_ptr<CtffdSource> prepared;
  FoundFeatures target_features;
  run_beside(
      2, [&] { prepared = std::make_unique<CtffdSource>(source, o.points_per_layer); },
      [&] { target_features = found_features(target, 1); });
  const double before = t0.seconds();
  RegistrationResult r = register_with(source, &prepared->impl(), target, o, &target_features);
  r.seconds += before;
  r.ctffd_seconds += before;
  return r;
}

RegistrationResult register_bodies(const CtffdSource& source, const TriangleMesh& target, const RegistrationOptions& o) {
  check_inputs(source.mesh(), target);
  return register_with(source.mesh(), o.method == RegistrationMethod::kCtffd ? &source.impl() : nullptr, target, o);
}

}  // namespace posekit
