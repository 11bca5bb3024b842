#include "posekit/io/bvh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>

#include "parse_util.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit {
using namespace io_detail;

namespace {

const char* channel_name(BvhChannel c) {
  switch (c) {
    case BvhChannel::kXposition:
      return "Xposition";
    case BvhChannel::kYposition:
      return "Yposition";
    case BvhChannel::kZposition:
      return "Zposition";
    case BvhChannel::kXrotation:
      return "Xrotation";
    case BvhChannel::kYrotation:
      return "Yrotation";
    case BvhChannel::kZrotation:
      return "Zrotation";
  }
  return "";
}

bool parse_channel(std::string_view s, BvhChannel& c) {
  for (BvhChannel k : {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition, BvhChannel::kXrotation,
                       BvhChannel::kYrotation, BvhChannel::kZrotation})
    if (s == channel_name(k)) {
      c = k;
      return true;
    }
  return false;
}

bool is_position(BvhChannel c) { return c == BvhChannel::kXposition || c == BvhChannel::kYposition || c == BvhChannel::kZposition; }

/// Token stream over the whole file (BVH allows braces and values on any line).
class TokenStream {
 public:
  TokenStream(const std::string& text, const std::string& file) : lines_(text, file) {}
  bool next(std::string_view& token) {
    while (index_ >= tokens_.size()) {
      std::string_view line;
      if (!lines_.next(line)) return false;
      split(line, tokens_);
      index_ = 0;
    }
    token = tokens_[index_++];
    return true;
  }
  std::string_view expect(const char* what) {
    std::string_view t;
    if (!next(t)) lines_.fail(std::string("file ends early: expected ") + what);
    return t;
  }
  void expect_word(std::string_view word) {
    const std::string_view t = expect(std::string(word).c_str());
    if (t != word) lines_.fail("expected '" + std::string(word) + "', got '" + printable(t) + "'");
  }
  double number(const char* what) { return lines_.to_double(expect(what), what); }
  const LineScanner& lines() const { return lines_; }
  /// The line scanner for reading on line by line; only where the current line is used up.
  LineScanner& remaining_lines() { return lines_; }
  bool at_line_end() const { return index_ >= tokens_.size(); }

 private:
  LineScanner lines_;
  std::vector<std::string_view> tokens_;
  size_t index_ = 0;
};

/// Reads the frames line by line: each holds exactly one value per channel, or the error names the
/// line. Fewer lines than `frames` has rows is an error; more are ignored with a warning naming them.
void read_frames(const std::string& path, LineScanner& lines, int channel_count, std::vector<std::string>* warnings,
                 Eigen::MatrixXd* frames) {
  const Eigen::Index nf = frames->rows();
  if (channel_count == 0) return;
  std::string_view line;
  std::vector<std::string_view> tok;
  Eigen::Index f = 0;
  long long extra = 0;
  long first_extra_line = 0;
  while (lines.next(line)) {
    split(line, tok);
    if (tok.empty()) continue;
    if (f == nf) {
      if (static_cast<int>(tok.size()) != channel_count)
        lines.fail("after the " + std::to_string(nf) + " frames the header declares ('Frames: " + std::to_string(nf) + "'): a line of " +
                   std::to_string(tok.size()) + " values, expected nothing more");
      if (extra++ == 0) first_extra_line = lines.line_number();
      continue;
    }
    if (static_cast<int>(tok.size()) != channel_count)
      lines.fail("frame " + std::to_string(f + 1) + " of " + std::to_string(nf) + " has " + std::to_string(tok.size()) +
                 " values, expected " + std::to_string(channel_count) + " (one per channel: a truncated or damaged line)");
    for (int c = 0; c < channel_count; ++c) {
      const double v = lines.to_double(tok[static_cast<size_t>(c)], "a channel value");
      if (!std::isfinite(v)) lines.fail("non-finite channel value in frame " + std::to_string(f + 1));
      (*frames)(f, c) = v;
    }
    ++f;
  }
  if (f < nf)
    throw IoError(path + ": the header declares " + std::to_string(nf) + " frames ('Frames: " + std::to_string(nf) + "'), the file has " +
                  std::to_string(f) + " (truncated file)");
  if (extra > 0)
    warn(warnings, path + ":" + std::to_string(first_extra_line) + ": " + std::to_string(extra) + " frame line(s) after the " +
                       std::to_string(nf) + " the header declares ('Frames: " + std::to_string(nf) +
                       "'): ignored (correct the count to use them)");
}

}  // namespace

int BvhMotion::find_joint(const std::string& name) const {
  for (size_t j = 0; j < joints.size(); ++j)
    if (joints[j].name == name) return static_cast<int>(j);
  return -1;
}

Eigen::Matrix3d BvhMotion::local_rotation(int frame, int joint) const {
  const BvhJoint& j = joints.at(joint);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  for (size_t c = 0; c < j.channels.size(); ++c) {
    const double angle = frames(frame, j.first_channel + static_cast<int>(c)) * M_PI / 180.0;
    switch (j.channels[c]) {
      case BvhChannel::kXrotation:
        R = R * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()).toRotationMatrix();
        break;
      case BvhChannel::kYrotation:
        R = R * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
        break;
      case BvhChannel::kZrotation:
        R = R * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        break;
      default:
        break;
    }
  }
  return R;
}

Eigen::Vector3d BvhMotion::local_translation(int frame, int joint) const {
  const BvhJoint& j = joints.at(joint);
  // Position channels are displacements added to the OFFSET (for the usual root OFFSET of zero
  // this is the same as an absolute position; MakeHuman writes non-zero offsets and deltas).
  Eigen::Vector3d t = j.offset;
  for (size_t c = 0; c < j.channels.size(); ++c) {
    const double v = frames(frame, j.first_channel + static_cast<int>(c));
    if (j.channels[c] == BvhChannel::kXposition) t.x() += v;
    if (j.channels[c] == BvhChannel::kYposition) t.y() += v;
    if (j.channels[c] == BvhChannel::kZposition) t.z() += v;
  }
  return t;
}

Eigen::MatrixXd BvhMotion::joint_positions(int frame) const {
  if (frame < 0 || frame >= num_frames()) throw InvalidInput("BVH frame " + std::to_string(frame) + " out of range");
  std::vector<Eigen::Matrix3d> R(joints.size());
  Eigen::MatrixXd P(joints.size(), 3);
  for (size_t j = 0; j < joints.size(); ++j) {
    const Eigen::Vector3d t = local_translation(frame, static_cast<int>(j));
    const Eigen::Matrix3d r = local_rotation(frame, static_cast<int>(j));
    const int p = joints[j].parent;
    if (p < 0) {
      R[j] = r;
      P.row(j) = t.transpose();
    } else {
      R[j] = R[p] * r;
      P.row(j) = (P.row(p).transpose() + R[p] * t).transpose();
    }
  }
  return P;
}

BvhMotion read_bvh(const std::string& path, Unit unit, std::vector<std::string>* warnings) {
  const double scale = metres_per_unit(unit);
  const std::string bytes = read_file_bytes(path);
  TokenStream ts(bytes, path);
  BvhMotion motion;
  int channel_count = 0;
  if (ts.expect("HIERARCHY") != "HIERARCHY") ts.lines().fail("expected 'HIERARCHY' (not a BVH file?)");
  // The hierarchy is walked with an explicit stack of open joints, so a corrupt or hostile file
  // nesting joints 100,000 deep costs memory in proportion to its size, never the call stack.
  std::vector<int> open;
  std::string_view t;  // the token after the part just read
  auto open_joint = [&](int parent) {
    BvhJoint joint;
    joint.parent = parent;
    joint.name = std::string(ts.expect("a joint name"));
    ts.expect_word("{");
    ts.expect_word("OFFSET");
    for (int k = 0; k < 3; ++k) joint.offset[k] = ts.number("an OFFSET value") * scale;
    t = ts.expect("CHANNELS, JOINT, End Site or }");
    if (t == "CHANNELS") {
      const double n = ts.number("the channel count");
      if (n < 0 || n > 6 || n != std::floor(n)) ts.lines().fail("CHANNELS count must be 0..6");
      joint.first_channel = channel_count;
      for (int c = 0; c < static_cast<int>(n); ++c) {
        BvhChannel ch;
        const std::string_view name = ts.expect("a channel name");
        if (!parse_channel(name, ch)) ts.lines().fail("unknown channel '" + printable(name) + "': expected X/Y/Z position or rotation");
        joint.channels.push_back(ch);
      }
      channel_count += static_cast<int>(n);
      t = ts.expect("JOINT, End Site or }");
    }
    open.push_back(static_cast<int>(motion.joints.size()));
    motion.joints.push_back(std::move(joint));
  };
  t = ts.expect("ROOT");
  while (t == "ROOT") {
    open_joint(-1);
    while (!open.empty()) {
      if (t == "JOINT") {
        open_joint(open.back());
        continue;
      }
      if (t == "End") {
        ts.expect_word("Site");
        ts.expect_word("{");
        ts.expect_word("OFFSET");
        Eigen::Vector3d end;
        for (int k = 0; k < 3; ++k) end[k] = ts.number("an End Site OFFSET value") * scale;
        ts.expect_word("}");
        motion.joints[open.back()].has_end_site = true;
        motion.joints[open.back()].end_offset = end;
      } else if (t == "}") {
        open.pop_back();
        if (open.empty()) break;
      } else {
        ts.lines().fail("expected JOINT, End Site or }, got '" + printable(t) + "'");
      }
      t = ts.expect("JOINT, End Site or }");
    }
    t = ts.expect("MOTION");
  }
  if (motion.joints.empty()) ts.lines().fail("expected 'ROOT'");
  if (t != "MOTION") ts.lines().fail("expected 'MOTION', got '" + printable(t) + "'");
  ts.expect_word("Frames:");
  const double nframes = ts.number("the frame count");
  if (nframes < 0 || nframes != std::floor(nframes) || nframes > 1e7) ts.lines().fail("bad frame count");
  ts.expect_word("Frame");
  ts.expect_word("Time:");
  motion.frame_time = ts.number("the frame time");
  if (!std::isfinite(motion.frame_time) || motion.frame_time <= 0)
    ts.lines().fail("Frame Time must be a positive number of seconds, got " + std::to_string(motion.frame_time));
  const auto nf = static_cast<Eigen::Index>(nframes);
  if (static_cast<double>(nf) * channel_count > static_cast<double>(bytes.size()))
    ts.lines().fail("the header declares " + std::to_string(nf) + " frames of " + std::to_string(channel_count) +
                    " channels, more than the file holds");
  if (!ts.at_line_end()) {
    std::string_view extra;
    ts.next(extra);
    ts.lines().fail("unexpected '" + printable(extra) + "' after the frame time: each frame goes on a line of its own");
  }
  motion.frames.resize(nf, channel_count);
  read_frames(path, ts.remaining_lines(), channel_count, warnings, &motion.frames);
  for (const BvhJoint& j : motion.joints)
    for (size_t c = 0; c < j.channels.size(); ++c)
      if (is_position(j.channels[c])) motion.frames.col(j.first_channel + static_cast<int>(c)) *= scale;
  return motion;
}

void write_bvh(const std::string& path, const BvhMotion& motion, Unit unit) {
  const double scale = 1.0 / metres_per_unit(unit);
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        out << std::setprecision(10) << "HIERARCHY\n";
        // Children lists once, then a depth-first walk with an explicit stack (no recursion).
        std::vector<std::vector<int>> children(motion.joints.size());
        for (size_t k = 0; k < motion.joints.size(); ++k)
          if (motion.joints[k].parent >= 0) children.at(motion.joints[k].parent).push_back(static_cast<int>(k));
        struct Visit {
          int joint;
          size_t next_child;
        };
        auto close = [&](int j, size_t depth) {
          const std::string pad(std::min<size_t>(depth, 32), '\t');  // readers ignore indentation
          const BvhJoint& joint = motion.joints[j];
          if (joint.has_end_site)
            out << pad << "\tEnd Site\n"
                << pad << "\t{\n"
                << pad << "\t\tOFFSET " << joint.end_offset.x() * scale << ' ' << joint.end_offset.y() * scale << ' '
                << joint.end_offset.z() * scale << '\n'
                << pad << "\t}\n";
          out << pad << "}\n";
        };
        auto open = [&](int j, size_t depth) {
          const std::string pad(std::min<size_t>(depth, 32), '\t');  // readers ignore indentation
          const BvhJoint& joint = motion.joints[j];
          out << pad << (joint.parent < 0 ? "ROOT " : "JOINT ") << joint.name << "\n" << pad << "{\n";
          out << pad << "\tOFFSET " << joint.offset.x() * scale << ' ' << joint.offset.y() * scale << ' ' << joint.offset.z() * scale
              << '\n';
          if (!joint.channels.empty()) {
            out << pad << "\tCHANNELS " << joint.channels.size();
            for (BvhChannel c : joint.channels) out << ' ' << channel_name(c);
            out << '\n';
          }
        };
        for (size_t root = 0; root < motion.joints.size(); ++root) {
          if (motion.joints[root].parent >= 0) continue;
          std::vector<Visit> stack{{static_cast<int>(root), 0}};
          open(static_cast<int>(root), 0);
          while (!stack.empty()) {
            Visit& top = stack.back();
            if (top.next_child < children[top.joint].size()) {
              const int child = children[top.joint][top.next_child++];
              open(child, stack.size());
              stack.push_back({child, 0});
            } else {
              close(top.joint, stack.size() - 1);
              stack.pop_back();
            }
          }
        }
        out << "MOTION\nFrames: " << motion.frames.rows() << "\nFrame Time: " << motion.frame_time << '\n';
        for (Eigen::Index f = 0; f < motion.frames.rows(); ++f) {
          for (const BvhJoint& joint : motion.joints)
            for (size_t c = 0; c < joint.channels.size(); ++c) {
              const double v = motion.frames(f, joint.first_channel + static_cast<int>(c));
              out << (is_position(joint.channels[c]) ? v * scale : v) << ' ';
            }
          out << '\n';
        }
      },
      false);
}

}  // namespace posekit
