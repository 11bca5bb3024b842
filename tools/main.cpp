// posekit: one executable, one subcommand per task (like git or colmap).
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>

#include "cli.h"
#include "commands.h"
#include "posekit/core/error.h"
#include "posekit/version.h"

namespace {

struct Command {
  const char* name;
  int (*run)(int, char**);
  const char* summary;
};

const Command kCommands[] = {
    {"info", posekit::cli::run_info, "counts, bounding box, units and validity of a mesh or point cloud"},
    {"convert", posekit::cli::run_convert, "convert between mesh/cloud formats and units"},
    {"body", posekit::cli::run_body, "build a MakeHuman body from sliders, pose it, write it"},
    {"measure", posekit::cli::run_measure, "stature and girths of a standing body mesh or scan"},
    {"customize", posekit::cli::run_customize, "a body from a front and a side photo (section 3.2); train, eval"},
    {"register", posekit::cli::run_register, "register a template to a body (ct-FFD or ICP) and match triangles"},
    {"shape-space", posekit::cli::run_shape_space, "learn a shape space file for register --shape-space"},
    {"segment", posekit::cli::run_segment, "segment a body into 16 parts (Eq. 2) and embed the skeleton"},
    {"train", posekit::cli::run_train, "learn the non-rigid pose deformation from a pose dataset (Eq. 3-5)"},
    {"pose", posekit::cli::run_pose, "pose a customized body from joint angles or a BVH (Eq. 1, 5-6)"},
    {"fit", posekit::cli::run_fit, "the 16-part pose that makes a body match a scan or mesh (articulated ICP, no markers)"},
    {"retarget", posekit::cli::run_retarget, "16-part pose JSONs from the frames of any humanoid BVH (CMU, Mixamo, ...)"},
    {"eval", posekit::cli::run_eval, "accuracy against ground truth (eval pose, eval bodies)"},
    {"compare", posekit::cli::run_compare, "a model against a scan: distances, coverage, girth discrepancies, heatmap"},
    {"view", posekit::cli::run_view, "VTK viewer for meshes with error fields (window, or --png off-screen)"},
    {"report", posekit::cli::run_report, "the paper's figures and tables from a dataset, as HTML + Markdown"},
    {"dataset", posekit::cli::run_dataset, "generate the evaluation dataset, or check one"},
    {"batch", posekit::cli::run_batch, "measure, compare or pose many bodies on several cores or machines (shards), with a CSV summary"},
    {"dev", posekit::cli::run_dev, "for posekit's developers: dev calibrate refits the body features' fitted constants"},
    {"bench", posekit::cli::run_bench, "benchmarks with medians over several runs; bench all: one table"},
};

void print_usage() {
  std::cout << "usage: posekit <command> [arguments] [--help]\n\n"
               "posekit: customize, pose and validate human body models (Zhu & Mok).\n\ncommands:\n";
  for (const auto& c : kCommands) std::cout << "  " << c.name << std::string(12 - std::strlen(c.name), ' ') << c.summary << "\n";
  std::cout << "\nRun 'posekit <command> --help' for the options of one command.\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    print_usage();
    return argc < 2 ? 2 : 0;
  }
  if (!std::strcmp(argv[1], "--version")) {
    std::cout << "posekit " << posekit::version() << "\n";
    return 0;
  }
  const std::string name = argv[1];
  for (const auto& c : kCommands) {
    if (name != c.name) continue;
    // Warnings of readers and writers are printed however the command ends.
    struct FlushWarnings {
      ~FlushWarnings() { posekit::cli::flush_warnings(); }
    } flush;
    try {
      return c.run(argc - 2, argv + 2);
    } catch (const posekit::cli::UsageError& e) {
      std::cerr << "posekit " << name << ": " << e.what() << "\n";
      return 2;
    } catch (const posekit::BelowConfidence& e) {
      std::cerr << "posekit " << name << ": below confidence: " << e.what() << "\n";
      return 3;
    } catch (const posekit::Error& e) {
      std::cerr << "posekit " << name << ": error: " << e.what() << "\n";
      return 1;
    } catch (const std::filesystem::filesystem_error& e) {
      // Not an internal error: the filesystem refused (read-only, no permission, no space).
      std::cerr << "posekit " << name << ": error: " << e.path1().string() << ": " << e.code().message() << "\n";
      return 1;
    } catch (const std::exception& e) {
      std::cerr << "posekit " << name << ": internal error: " << e.what() << "\n";
      return 1;
    }
  }
  std::cerr << "posekit: unknown command '" << name << "' (run 'posekit --help' for the list)\n";
  return 2;
}
