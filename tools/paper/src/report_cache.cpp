#include "report_cache.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/version.h"

namespace fs = std::filesystem;

namespace posekit::report_detail {
namespace {

std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::string stamp_of(const fs::path& p) {
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  const auto time = fs::last_write_time(p, ec);
  if (ec) return p.string() + " (missing)";
  return p.string() + " " + std::to_string(size) + " " + std::to_string(time.time_since_epoch().count());
}

}  // namespace

ResultCache::ResultCache(std::string dir) : dir_(std::move(dir)) {
  if (dir_.empty()) return;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (!fs::is_directory(dir_, ec)) throw IoError(dir_ + ": cannot create the cache folder (" + ec.message() + ")");
}

std::string ResultCache::path(const std::string& what, const std::string& inputs, const std::string& extension) const {
  if (dir_.empty()) return "";
  char key[17];
  std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(fnv1a(what + "\n" + inputs)));
  std::string name = what;
  std::replace(name.begin(), name.end(), ' ', '-');
  return (fs::path(dir_) / (name + "-" + key + extension)).string();
}

std::string folder_fingerprint(const std::string& dir) {
  std::vector<std::string> stamps;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
    if (it->is_regular_file(ec)) stamps.push_back(stamp_of(it->path()));
  std::sort(stamps.begin(), stamps.end());
  std::string all = fs::absolute(dir, ec).string();
  for (const auto& s : stamps) all += "\n" + s;
  return all;
}

std::string file_fingerprint(const std::string& path) {
  std::error_code ec;
  return stamp_of(fs::absolute(path, ec));
}

std::string binary_fingerprint() {
  Dl_info info{};
  std::string self = "/proc/self/exe";
  if (dladdr(reinterpret_cast<void*>(&binary_fingerprint), &info) != 0 && info.dli_fname &&
      std::string(info.dli_fname).find('/') != std::string::npos)
    self = info.dli_fname;
  std::error_code ec;
  const fs::path resolved = fs::canonical(self, ec);
  return std::string("posekit ") + version() + " " + stamp_of(ec ? fs::path(self) : resolved);
}

void write_pose_fit(const std::string& path, const PoseFitResult& fit) {
  const nlohmann::json head = {{"format", "posekit report pose fit 1"},
                               {"pose", part_pose_to_json(fit.pose)},
                               {"vertices", fit.V.rows()},
                               {"warnings", fit.warnings}};
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> V = fit.V;
  write_file_atomically(path, [&](std::ostream& out) {
    out << head.dump() << "\n";
    out.write(reinterpret_cast<const char*>(V.data()), static_cast<std::streamsize>(sizeof(double) * V.size()));
  });
}

bool read_pose_fit(const std::string& path, PoseFitResult* fit) {
  try {
    const std::string bytes = read_file_bytes(path);
    const size_t line = bytes.find('\n');
    if (line == std::string::npos) return false;
    const nlohmann::json head = nlohmann::json::parse(bytes.substr(0, line));
    if (head.at("format") != "posekit report pose fit 1") return false;
    const auto rows = head.at("vertices").get<Eigen::Index>();
    if (rows < 0 || bytes.size() - line - 1 != sizeof(double) * 3 * static_cast<size_t>(rows)) return false;
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> V(rows, 3);
    std::memcpy(V.data(), bytes.data() + line + 1, sizeof(double) * 3 * static_cast<size_t>(rows));
    fit->pose = part_pose_from_json(head.at("pose").get<std::string>(), path);
    fit->V = V;
    fit->warnings = head.at("warnings").get<std::vector<std::string>>();
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

nlohmann::json registration_table_to_json(const RegistrationTable& t) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : t.rows)
    rows.push_back({{"method", r.method},
                    {"seconds", r.seconds},
                    {"median_s", r.median_s},
                    {"min_s", r.min_s},
                    {"max_s", r.max_s},
                    {"point_mean_mm", r.point_mean_mm},
                    {"point_p95_mm", r.point_p95_mm},
                    {"point_max_mm", r.point_max_mm},
                    {"worst_subject_point_mean_mm", r.worst_subject_point_mean_mm},
                    {"subject_point_mean_mm", r.subject_point_mean_mm},
                    {"mean_error_mm", r.mean_error_mm},
                    {"p95_error_mm", r.p95_error_mm},
                    {"worst_subject_mean_error_mm", r.worst_subject_mean_error_mm},
                    {"subject_mean_error_mm", r.subject_mean_error_mm},
                    {"pose_transfer_mm", r.pose_transfer_mm},
                    {"subjects", r.subjects}});
  nlohmann::json others = nlohmann::json::array();
  for (const auto& o : t.other_targets) others.push_back(registration_table_to_json(o));
  return {{"targets", t.targets},
          {"template_vertices", t.template_vertices},
          {"template_triangles", t.template_triangles},
          {"mean_subject_vertices", t.mean_subject_vertices},
          {"mean_subject_triangles", t.mean_subject_triangles},
          {"subject_ids", t.subject_ids},
          {"triangle_floor_mean_mm", t.triangle_floor_mean_mm},
          {"triangle_floor_p95_mm", t.triangle_floor_p95_mm},
          {"pose_transfer_true_mm", t.pose_transfer_true_mm},
          {"ctffd_template_seconds", t.ctffd_template_seconds},
          {"rows", rows},
          {"other_targets", others}};
}

RegistrationTable registration_table_from_json(const nlohmann::json& j) {
  RegistrationTable t;
  j.at("targets").get_to(t.targets);
  j.at("template_vertices").get_to(t.template_vertices);
  j.at("template_triangles").get_to(t.template_triangles);
  j.at("mean_subject_vertices").get_to(t.mean_subject_vertices);
  j.at("mean_subject_triangles").get_to(t.mean_subject_triangles);
  j.at("subject_ids").get_to(t.subject_ids);
  j.at("triangle_floor_mean_mm").get_to(t.triangle_floor_mean_mm);
  j.at("triangle_floor_p95_mm").get_to(t.triangle_floor_p95_mm);
  j.at("pose_transfer_true_mm").get_to(t.pose_transfer_true_mm);
  j.at("ctffd_template_seconds").get_to(t.ctffd_template_seconds);
  for (const auto& jr : j.at("rows")) {
    RegistrationTableRow r;
    jr.at("method").get_to(r.method);
    jr.at("seconds").get_to(r.seconds);
    jr.at("median_s").get_to(r.median_s);
    jr.at("min_s").get_to(r.min_s);
    jr.at("max_s").get_to(r.max_s);
    jr.at("point_mean_mm").get_to(r.point_mean_mm);
    jr.at("point_p95_mm").get_to(r.point_p95_mm);
    jr.at("point_max_mm").get_to(r.point_max_mm);
    jr.at("worst_subject_point_mean_mm").get_to(r.worst_subject_point_mean_mm);
    jr.at("subject_point_mean_mm").get_to(r.subject_point_mean_mm);
    jr.at("mean_error_mm").get_to(r.mean_error_mm);
    jr.at("p95_error_mm").get_to(r.p95_error_mm);
    jr.at("worst_subject_mean_error_mm").get_to(r.worst_subject_mean_error_mm);
    jr.at("subject_mean_error_mm").get_to(r.subject_mean_error_mm);
    jr.at("pose_transfer_mm").get_to(r.pose_transfer_mm);
    jr.at("subjects").get_to(r.subjects);
    t.rows.push_back(std::move(r));
  }
  for (const auto& o : j.at("other_targets")) t.other_targets.push_back(registration_table_from_json(o));
  return t;
}

}  // namespace posekit::report_detail
