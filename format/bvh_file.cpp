#include "format/bvh_file.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <stdexcept>

#include "format/atomic_file.h"
#include "format/input_error.h"

namespace mm {

const char* bvh_channel_name(BvhChannel channel) {
  switch (channel) {
    case BvhChannel::kXposition: return "Xposition";
    case BvhChannel::kYposition: return "Yposition";
    case BvhChannel::kZposition: return "Zposition";
    case BvhChannel::kXrotation: return "Xrotation";
    case BvhChannel::kYrotation: return "Yrotation";
    case BvhChannel::kZrotation: return "Zrotation";
  }
  return "?";
}

bool parse_bvh_channel(const std::string& text, BvhChannel* channel) {
  static const BvhChannel all[] = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition,
                                   BvhChannel::kXrotation, BvhChannel::kYrotation, BvhChannel::kZrotation};
  for (BvhChannel candidate : all) {
    if (text == bvh_channel_name(candidate)) {
      *channel = candidate;
      return true;
    }
  }
  return false;
}

int bvh_channel_axis(BvhChannel channel) { return static_cast<int>(channel) % 3; }
bool bvh_channel_is_position(BvhChannel channel) { return static_cast<int>(channel) < 3; }

double bvh_frame_rate(const BvhFile& file) {
  const double rate = std::round(1e6 / file.frame_time_s) / 1e6;
  // A frame time of 8 significant digits (0.00833333, CMU's) is 120.000048
  // Hz: within a millionth of a whole number of hertz, it is that rate, the
  // one the file was written at.
  const double written_at = std::round(rate);
  return std::abs(rate - written_at) <= 1e-6 * rate ? written_at : rate;
}

int BvhFile::channel_count() const {
  int count = 0;
  for (const auto& joint : joints) count += static_cast<int>(joint.channels.size());
  return count;
}

int64_t BvhFile::frame_count() const {
  const int channels = channel_count();
  return channels > 0 ? static_cast<int64_t>(values.size() / channels) : 0;
}

std::vector<int> BvhFile::first_channels() const {
  std::vector<int> first(joints.size());
  int next = 0;
  for (size_t j = 0; j < joints.size(); ++j) {
    first[j] = next;
    next += static_cast<int>(joints[j].channels.size());
  }
  return first;
}

int BvhFile::named_joint_count() const {
  int count = 0;
  for (const auto& joint : joints) count += joint.end_site ? 0 : 1;
  return count;
}

namespace {

// A whitespace-separated word with the line it starts on.
struct Token {
  std::string text;
  int64_t line = 0;
};

// Splits the hierarchy into tokens while counting lines. Line ends are
// '\n', with any '\r' before them treated as space, so LF, CRLF and mixed
// files (the CMU set has both) read alike.
class Tokenizer {
 public:
  Tokenizer(const char* data, size_t size, const std::string& source) : data_(data), size_(size), source_(source) {
    if (size_ >= 3 && std::memcmp(data_, "\xEF\xBB\xBF", 3) == 0) pos_ = 3;
  }

  bool at_end() {
    skip_space();
    return pos_ >= size_;
  }

  Token next(const char* expected) {
    skip_space();
    if (pos_ >= size_) fail(line_, std::string("unexpected end of file, expected ") + expected);
    Token token;
    token.line = line_;
    const size_t start = pos_;
    while (pos_ < size_ && !is_space(data_[pos_])) ++pos_;
    // A word longer than any name or number is no BVH; refusing it keeps
    // messages short.
    if (pos_ - start > 1000) fail(line_, std::string("a word of ") + std::to_string(pos_ - start) +
                                             " characters, expected " + expected);
    token.text.assign(data_ + start, pos_ - start);
    return token;
  }

  // Moves past the end of the current line; the motion section is read line by line.
  void skip_rest_of_line() {
    while (pos_ < size_ && data_[pos_] != '\n') {
      if (!is_space(data_[pos_])) fail(line_, "unexpected text after the frame time");
      ++pos_;
    }
    if (pos_ < size_) {
      ++pos_;
      ++line_;
    }
  }

  // The next line without its line end; false at the end of the data.
  bool next_line(const char** begin, const char** end, int64_t* line) {
    if (pos_ >= size_) return false;
    *begin = data_ + pos_;
    *line = line_;
    const void* newline = std::memchr(data_ + pos_, '\n', size_ - pos_);
    const size_t stop = newline ? static_cast<size_t>(static_cast<const char*>(newline) - data_) : size_;
    *end = data_ + stop;
    pos_ = newline ? stop + 1 : size_;
    ++line_;
    return true;
  }

  [[noreturn]] void fail(int64_t line, const std::string& message) const {
    throw InputError(source_ + ":" + std::to_string(line) + ": " + message);
  }

  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

 private:
  void skip_space() {
    while (pos_ < size_ && is_space(data_[pos_])) {
      if (data_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  const char* data_;
  size_t size_;
  size_t pos_ = 0;
  int64_t line_ = 1;
  const std::string& source_;
};

std::string quoted(const std::string& text) { return "\"" + text + "\""; }

// A finite number that is the whole of `text`, within +-bound.
double parse_number(const Tokenizer& tokens, const Token& token, double bound, const char* what) {
  // from_chars: exact like strtod and several times faster on the millions
  // of values of a long take; it takes no '+', which some writers emit.
  const char* begin = token.text.c_str();
  const char* end = begin + token.text.size();
  const char* number = (begin != end && *begin == '+') ? begin + 1 : begin;
  double value = 0;
  auto [parsed_end, error] = std::from_chars(number, end, value);
  // Beyond a double's range from_chars leaves `value` alone; strtod gives
  // the infinity or the denormal or zero that the range check below reads.
  if (error == std::errc::result_out_of_range) value = std::strtod(begin, nullptr), error = std::errc();
  if (number == end || parsed_end != end || error != std::errc()) {
    tokens.fail(token.line, quoted(token.text) + " is not a number, expected " + what);
  }
  if (!std::isfinite(value) || std::fabs(value) > bound) {
    char limit[32];
    std::snprintf(limit, sizeof limit, "%g", bound);
    tokens.fail(token.line, quoted(token.text) + " is out of range, expected " + what + " within +-" + limit);
  }
  return value;
}

void expect_word(Tokenizer& tokens, const char* word) {
  const Token token = tokens.next(word);
  if (token.text != word) tokens.fail(token.line, "found " + quoted(token.text) + ", expected " + quoted(word));
}

// The body of a joint after its "{": OFFSET, then CHANNELS unless it is an
// End Site.
void parse_joint_header(Tokenizer& tokens, BvhJoint& joint) {
  expect_word(tokens, "OFFSET");
  for (int k = 0; k < 3; ++k) {
    joint.offset[k] = parse_number(tokens, tokens.next("an offset value"), kMaxBvhLength, "an offset value");
  }
  if (joint.end_site) return;
  expect_word(tokens, "CHANNELS");
  const Token count_token = tokens.next("a channel count");
  const double count = parse_number(tokens, count_token, 1e9, "a channel count");
  if (count != std::floor(count) || count < 0 || count > 6) {
    tokens.fail(count_token.line, "channel count " + count_token.text + ", expected 0 to 6");
  }
  std::set<BvhChannel> seen;
  for (int c = 0; c < static_cast<int>(count); ++c) {
    const Token name = tokens.next("a channel name");
    BvhChannel channel;
    if (!parse_bvh_channel(name.text, &channel)) {
      tokens.fail(name.line, "channel " + quoted(name.text) + " of joint " + joint.name +
                                 ", expected one of Xposition Yposition Zposition Xrotation Yrotation Zrotation "
                                 "(the CHANNELS count is " + count_token.text + ")");
    }
    if (!seen.insert(channel).second) {
      tokens.fail(name.line, "channel " + name.text + " of joint " + joint.name + " appears twice");
    }
    joint.channels.push_back(channel);
  }
}

void parse_hierarchy(Tokenizer& tokens, BvhFile& file) {
  expect_word(tokens, "HIERARCHY");
  expect_word(tokens, "ROOT");
  std::set<std::string> names;
  std::vector<int> open;  // joints whose "}" is still to come, innermost last
  auto begin_joint = [&](int parent, bool end_site, const Token& at) {
    if (static_cast<int>(file.joints.size()) >= kMaxBvhJoints) {
      tokens.fail(at.line, "more than " + std::to_string(kMaxBvhJoints) + " joints");
    }
    BvhJoint joint;
    joint.parent = parent;
    joint.end_site = end_site;
    if (!end_site) {
      joint.name = tokens.next("a joint name").text;
      if (!names.insert(joint.name).second) tokens.fail(at.line, "joint name " + quoted(joint.name) + " appears twice");
    } else {
      expect_word(tokens, "Site");
    }
    expect_word(tokens, "{");
    parse_joint_header(tokens, joint);
    file.joints.push_back(std::move(joint));
    open.push_back(static_cast<int>(file.joints.size()) - 1);
  };
  begin_joint(-1, false, Token{"ROOT", 1});
  while (!open.empty()) {
    const Token token = tokens.next("JOINT, End Site or }");
    const int current = open.back();
    if (token.text == "}") {
      open.pop_back();
    } else if (file.joints[current].end_site) {
      tokens.fail(token.line, "found " + quoted(token.text) + " in an End Site, expected }");
    } else if (token.text == "JOINT") {
      begin_joint(current, false, token);
    } else if (token.text == "End") {
      begin_joint(current, true, token);
    } else if (token.text == "ROOT") {
      tokens.fail(token.line, "a second ROOT inside joint " + file.joints[current].name +
                                  "; only one skeleton a file is supported");
    } else {
      tokens.fail(token.line, "found " + quoted(token.text) + " in joint " + file.joints[current].name +
                                  ", expected JOINT, End Site or }");
    }
  }
}

void parse_motion(Tokenizer& tokens, BvhFile& file, const std::string& source, const BvhFrameLimit& limit) {
  const int channels = file.channel_count();
  if (tokens.at_end()) throw InputError(source + ": no MOTION section after the hierarchy");
  const Token motion = tokens.next("MOTION");
  if (motion.text == "ROOT") tokens.fail(motion.line, "a second ROOT; only one skeleton a file is supported");
  if (motion.text != "MOTION") tokens.fail(motion.line, "found " + quoted(motion.text) + ", expected MOTION");
  if (channels == 0) tokens.fail(motion.line, "the hierarchy has no channels, so frames cannot hold values");
  expect_word(tokens, "Frames:");
  const Token count_token = tokens.next("the frame count");
  const double declared = parse_number(tokens, count_token, 1e15, "a frame count");
  if (declared != std::floor(declared) || declared < 1) {
    tokens.fail(count_token.line, "frame count " + count_token.text + ", expected a whole number >= 1");
  }
  expect_word(tokens, "Frame");
  expect_word(tokens, "Time:");
  const Token time_token = tokens.next("the frame time");
  file.frame_time_s = parse_number(tokens, time_token, 1e300, "a frame time in seconds");
  if (!(file.frame_time_s >= kMinBvhFrameTime && file.frame_time_s <= kMaxBvhFrameTime)) {
    tokens.fail(time_token.line, "frame time " + time_token.text +
                                     " s, expected 0.001 to 1 s (1 to 1000 frames a second)");
  }
  // What the frames will cost is known now, before any of them is read.
  const int64_t imported = bvh_imported_frame_count(static_cast<int64_t>(declared), file.frame_time_s);
  if (imported > limit.frames) {
    tokens.fail(time_token.line, count_token.text + " frames of " + time_token.text + " s make " +
                                     std::to_string(imported) + " frames at 25 Hz, more than the " +
                                     std::to_string(limit.frames) + " of " + limit.name);
  }
  tokens.skip_rest_of_line();

  const std::vector<int> first = file.first_channels();
  std::vector<char> is_rotation(channels);
  for (size_t j = 0; j < file.joints.size(); ++j) {
    for (size_t c = 0; c < file.joints[j].channels.size(); ++c) {
      is_rotation[first[j] + c] = !bvh_channel_is_position(file.joints[j].channels[c]);
    }
  }
  const int64_t expected_frames = static_cast<int64_t>(declared);
  int64_t frames = 0;
  int64_t blank_line = 0;  // a blank line seen after frames, for a better message
  const char *begin, *end;
  int64_t line;
  std::string number;
  while (tokens.next_line(&begin, &end, &line)) {
    const char* p = begin;
    while (p < end && Tokenizer::is_space(*p)) ++p;
    if (p == end) {
      if (frames > 0 && blank_line == 0) blank_line = line;
      continue;
    }
    if (blank_line != 0) tokens.fail(line, "a frame after the blank line " + std::to_string(blank_line));
    if (frames == expected_frames) {
      tokens.fail(line, "more frames than the " + count_token.text + " that \"Frames:\" declares");
    }
    int count = 0;
    while (p < end) {
      const char* stop = p;
      while (stop < end && !Tokenizer::is_space(*stop)) ++stop;
      if (count == channels) {
        tokens.fail(line, "more than " + std::to_string(channels) + " values in frame " + std::to_string(frames + 1) +
                              ", expected " + std::to_string(channels) + " (one a channel)");
      }
      if (stop - p > 1000) tokens.fail(line, "a value of " + std::to_string(stop - p) + " characters");
      number.assign(p, stop);
      const bool rotation = is_rotation[count];
      file.values.push_back(parse_number(tokens, Token{number, line},
                                         rotation ? kMaxBvhRotationDegrees : kMaxBvhLength,
                                         rotation ? "a rotation in degrees" : "a position"));
      ++count;
      p = stop;
      while (p < end && Tokenizer::is_space(*p)) ++p;
    }
    if (count != channels) {
      tokens.fail(line, std::to_string(count) + " values in frame " + std::to_string(frames + 1) + ", expected " +
                            std::to_string(channels) + " (one a channel)");
    }
    ++frames;
  }
  if (frames != expected_frames) {
    throw InputError(source + ": \"Frames:\" declares " + count_token.text + " frames but the file holds " +
                     std::to_string(frames));
  }
}

}  // namespace

int64_t bvh_imported_frame_count(int64_t frames, double frame_time_s) {
  if (frames < 1) return 0;
  // 1e-9 keeps k/25 that equals a frame's time up to rounding on that frame.
  return static_cast<int64_t>(std::floor(static_cast<double>(frames - 1) * frame_time_s * kBvhImportRate + 1e-9)) + 1;
}

BvhFile parse_bvh_text(const char* data, size_t size, const std::string& source_name, const BvhFrameLimit& limit) {
  Tokenizer tokens(data, size, source_name);
  if (tokens.at_end()) throw InputError(source_name + ": empty file, expected BVH (HIERARCHY ...)");
  BvhFile file;
  parse_hierarchy(tokens, file);
  parse_motion(tokens, file, source_name, limit);
  return file;
}

BvhFile parse_bvh_text(const std::string& text, const std::string& source_name, const BvhFrameLimit& limit) {
  return parse_bvh_text(text.data(), text.size(), source_name, limit);
}

BvhFile read_bvh_file(const std::string& path) {
  const std::string text = read_whole_file(path);
  return parse_bvh_text(text, path);
}

std::string write_bvh_text(const BvhFile& file) {
  const int channels = file.channel_count();
  if (file.joints.empty()) throw InputError("BVH writer: no joints");
  if (channels == 0 || file.values.size() % channels != 0) {
    throw InputError("BVH writer: " + std::to_string(file.values.size()) + " values is not a whole number of frames of " +
                     std::to_string(channels) + " channels");
  }
  std::string out = "HIERARCHY\n";
  char buffer[128];
  std::vector<int> open;  // the path from the root to the joint just written
  for (size_t j = 0; j < file.joints.size(); ++j) {
    const BvhJoint& joint = file.joints[j];
    // Depth-first pre-order means the parent is on the open path: close
    // every joint below it.
    while (!open.empty() && open.back() != joint.parent) {
      open.pop_back();
      out += std::string(open.size(), '\t') + "}\n";
    }
    if ((j == 0) != (joint.parent == -1) || (j > 0 && open.empty())) {
      throw InputError("BVH writer: joint " + std::to_string(j) + " is not in depth-first order");
    }
    if (!open.empty() && file.joints[open.back()].end_site) {
      throw InputError("BVH writer: joint " + std::to_string(j) + " is the child of an End Site");
    }
    if (joint.end_site && !joint.channels.empty()) {
      throw InputError("BVH writer: End Site " + std::to_string(j) + " has channels");
    }
    const std::string indent(open.size(), '\t');
    if (joint.end_site) {
      out += indent + "End Site\n";
    } else {
      out += indent + (j == 0 ? "ROOT " : "JOINT ") + joint.name + "\n";
    }
    out += indent + "{\n";
    std::snprintf(buffer, sizeof buffer, "\tOFFSET %.6f %.6f %.6f\n", joint.offset[0], joint.offset[1], joint.offset[2]);
    out += indent + buffer;
    if (!joint.end_site) {
      out += indent + "\tCHANNELS " + std::to_string(joint.channels.size());
      for (BvhChannel channel : joint.channels) out += std::string(" ") + bvh_channel_name(channel);
      out += "\n";
    }
    open.push_back(static_cast<int>(j));
  }
  while (!open.empty()) {
    open.pop_back();
    out += std::string(open.size(), '\t') + "}\n";
  }
  std::snprintf(buffer, sizeof buffer, "MOTION\nFrames: %lld\nFrame Time: %.9g\n",
                static_cast<long long>(file.frame_count()), file.frame_time_s);
  out += buffer;
  out.reserve(out.size() + file.values.size() * 11);
  for (size_t i = 0; i < file.values.size(); ++i) {
    // "%.6f" as printf writes it (both round exactly), several times faster.
    const auto written = std::to_chars(buffer, buffer + sizeof buffer, file.values[i], std::chars_format::fixed, 6);
    out.append(buffer, written.ptr);
    out += ((i + 1) % channels == 0) ? '\n' : ' ';
  }
  return out;
}

void write_bvh_file(const BvhFile& file, const std::string& path) { write_file_atomically(path, write_bvh_text(file)); }

std::vector<Vec3> bvh_world_positions(const BvhFile& file, int64_t frame) {
  if (frame < 0 || frame >= file.frame_count()) throw std::out_of_range("bvh_world_positions: frame out of range");
  const int channels = file.channel_count();
  const double* values = file.values.data() + frame * channels;
  std::vector<Vec3> position(file.joints.size());
  std::vector<Mat3> rotation(file.joints.size());
  int next = 0;
  for (size_t j = 0; j < file.joints.size(); ++j) {
    const BvhJoint& joint = file.joints[j];
    Vec3 local_position = joint.offset;
    Mat3 local = identity_matrix();
    for (BvhChannel channel : joint.channels) {
      const double value = values[next++];
      if (bvh_channel_is_position(channel)) {
        local_position[bvh_channel_axis(channel)] += value;
      } else {
        local = multiply(local, axis_rotation(bvh_channel_axis(channel), value * 3.14159265358979323846 / 180.0));
      }
    }
    if (joint.parent < 0) {
      position[j] = local_position;
      rotation[j] = local;
    } else {
      const Vec3 moved = multiply(rotation[joint.parent], local_position);
      for (int k = 0; k < 3; ++k) position[j][k] = position[joint.parent][k] + moved[k];
      rotation[j] = multiply(rotation[joint.parent], local);
    }
  }
  return position;
}

Skeleton bvh_skeleton(const BvhFile& file, const std::string& name, double millimetres_per_unit) {
  Skeleton skeleton;
  skeleton.name = name;
  std::set<std::string> names;
  for (const auto& joint : file.joints) {
    if (!joint.end_site) names.insert(joint.name);
  }
  for (const auto& joint : file.joints) {
    Joint out;
    out.parent = joint.parent;
    for (int k = 0; k < 3; ++k) out.offset_mm[k] = joint.offset[k] * millimetres_per_unit;
    if (joint.end_site) {
      const std::string base = file.joints[joint.parent].name + "_End";
      std::string candidate = base;
      for (int n = 2; names.count(candidate) > 0; ++n) candidate = base + "_" + std::to_string(n);
      names.insert(candidate);
      out.name = candidate;
    } else {
      out.name = joint.name;
    }
    skeleton.joints.push_back(std::move(out));
  }
  BvhLayout layout;
  layout.millimetres_per_unit = millimetres_per_unit;
  for (const auto& joint : file.joints) {
    std::vector<std::string> channels;
    for (BvhChannel channel : joint.channels) channels.push_back(bvh_channel_name(channel));
    layout.channels.push_back(std::move(channels));
    layout.end_site.push_back(joint.end_site);
  }
  skeleton.bvh = std::move(layout);
  return skeleton;
}

}  // namespace mm
