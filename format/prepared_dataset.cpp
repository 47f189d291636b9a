#include "format/prepared_dataset.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "format/h36m_corpus.h"
#include "format/input_error.h"

namespace mm {

namespace {

using nlohmann::json;

constexpr char kMagic[8] = {'M', 'M', 'P', 'R', 'E', 'P', '\r', '\n'};
constexpr uint32_t kVersion = 1;
// Quantisation grid: 2^13 levels per standard deviation, i.e. an error of at
// most 2^-14 = 6.1e-5 std, about the precision of the 7-decimal text for the
// least varying kept columns. A fixed grid (rather than min..max per
// dimension) keeps the error independent of outliers: some dimensions reach
// 200 std, where 16 bits over the range would err by 1.7e-3 std.
constexpr double kLevelsPerStd = 8192.0;
constexpr double kMaxLevel = 1 << 29;  // so differences stay within int32
constexpr size_t kPlanes = 4;  // bytes of a zigzag-coded int32 difference

// Zigzag maps small differences of either sign to small codes (0, -1, 1, -2
// -> 0, 1, 2, 3), so their upper byte planes are all zero and compress away.
uint32_t zigzag(int32_t value) {
  return (static_cast<uint32_t>(value) << 1) ^ static_cast<uint32_t>(value >> 31);
}
uint32_t unzigzag(uint32_t code) { return (code >> 1) ^ (0u - (code & 1u)); }

void put_u32(std::string& out, uint32_t value) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}

void put_u64(std::string& out, uint64_t value) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}

// Bounds-checked little-endian reader; every short read is a truncated file.
class Reader {
 public:
  Reader(const std::string& bytes, const std::string& path) : bytes_(bytes), path_(path) {}

  const char* take(uint64_t size, const char* what) {
    if (size > bytes_.size() - position_) {
      throw InputError(path_ + ": truncated file: " + what + " needs " + std::to_string(size) +
                       " bytes at offset " + std::to_string(position_) + ", file has " +
                       std::to_string(bytes_.size()) + " bytes");
    }
    const char* data = bytes_.data() + position_;
    position_ += size;
    return data;
  }
  uint64_t u64(const char* what) { return little_endian(take(8, what), 8); }
  uint32_t u32(const char* what) { return static_cast<uint32_t>(little_endian(take(4, what), 4)); }
  size_t remaining() const { return bytes_.size() - position_; }

 private:
  static uint64_t little_endian(const char* data, int size) {
    uint64_t value = 0;
    for (int i = size - 1; i >= 0; --i) value = (value << 8) | static_cast<unsigned char>(data[i]);
    return value;
  }
  const std::string& bytes_;
  const std::string& path_;
  size_t position_ = 0;
};

bool is_subject_in(const std::string& subject, const std::vector<std::string>& subjects) {
  return std::find(subjects.begin(), subjects.end(), subject) != subjects.end();
}

}  // namespace

std::vector<const PreparedSequence*> PreparedDataset::subset(
    const std::vector<std::string>& subjects) const {
  std::vector<const PreparedSequence*> result;
  for (const PreparedSequence& sequence : sequences) {
    if (is_subject_in(sequence.subject, subjects)) result.push_back(&sequence);
  }
  return result;
}

PreparedDataset prepare_h36m(const std::string& dataset_dir, const SplitOptions& options) {
  if (options.train_subjects.empty()) {
    throw InputError("prepare_h36m", "train_subjects is empty, expected at least one subject");
  }
  for (const std::string& subject : options.test_subjects) {
    if (is_subject_in(subject, options.train_subjects)) {
      throw InputError("prepare_h36m", "subject \"" + subject +
                       "\" is listed as both train and test subject");
    }
  }
  if (options.downsample < 1 || 50 % options.downsample != 0) {
    throw InputError("prepare_h36m", "downsample " + std::to_string(options.downsample) +
                     " is invalid, expected a divisor of 50 (the recording rate in Hz)");
  }
  std::vector<std::string> all_subjects = options.train_subjects;
  all_subjects.insert(all_subjects.end(), options.test_subjects.begin(), options.test_subjects.end());
  std::vector<MotionSequence> corpus = load_h36m_corpus(dataset_dir, all_subjects, options.downsample);

  PreparedDataset data;
  data.train_subjects = options.train_subjects;
  data.test_subjects = options.test_subjects;
  data.frame_rate = static_cast<int>(kH36mFrameRate) / options.downsample;
  std::vector<const MotionFrames*> train;
  for (const MotionSequence& sequence : corpus) {
    if (is_subject_in(sequence.subject, options.train_subjects)) train.push_back(&sequence.frames);
  }
  // Test subjects must not leak into the statistics the model is trained with.
  data.normalization = PoseNormalization::fit(train, options.min_std, true);
  data.sequences.reserve(corpus.size());
  for (MotionSequence& sequence : corpus) {
    PreparedSequence prepared;
    prepared.subject = std::move(sequence.subject);
    prepared.action = std::move(sequence.action);
    prepared.take = sequence.take;
    prepared.phase = sequence.phase;
    prepared.normalized = data.normalization.normalize(sequence.frames);
    sequence.frames.values = {};  // release raw frames early: the full set is ~170 MB
    data.sequences.push_back(std::move(prepared));
  }
  return data;
}

void save_prepared_dataset(const PreparedDataset& data, const std::string& path) {
  const int dims = data.normalization.dims();
  if (dims <= 0) throw InputError(path + ": normalization has no kept columns");
  uint64_t total_values = 0;
  for (size_t s = 0; s < data.sequences.size(); ++s) {
    const MotionFrames& frames = data.sequences[s].normalized;
    if (frames.columns != dims) {
      throw InputError(path + ": sequence " + std::to_string(s) + " has " +
                       std::to_string(frames.columns) + " columns, expected " + std::to_string(dims));
    }
    for (const float value : frames.values) {
      // Beyond kMaxLevel steps the int32 differences could overflow; such a
      // value (> 100000 std from the mean) means broken data, not motion.
      if (!std::isfinite(value) || std::abs(value) * kLevelsPerStd > kMaxLevel) {
        throw InputError(path + ": sequence " + std::to_string(s) + " holds the value " +
                         std::to_string(value) + ", expected a finite standardised value");
      }
    }
    total_values += frames.values.size();
  }
  json header;
  header["normalization"] = json::parse(data.normalization.to_json_text());
  header["train_subjects"] = data.train_subjects;
  header["test_subjects"] = data.test_subjects;
  header["frame_rate"] = data.frame_rate;
  header["dims"] = dims;
  header["levels_per_std"] = kLevelsPerStd;
  header["skeleton"] = json::parse(data.skeleton.to_json_text());
  if (!data.rig_folder.empty()) header["bvh_folder"] = data.rig_folder;
  json sequences = json::array();
  for (const PreparedSequence& sequence : data.sequences) {
    sequences.push_back({{"subject", sequence.subject},
                         {"action", sequence.action},
                         {"take", sequence.take},
                         {"phase", sequence.phase},
                         {"frames", sequence.normalized.frame_count()}});
  }
  header["sequences"] = std::move(sequences);

  // Payload in byte planes: plane p (0 = least significant) of value n at
  // p * N + n.
  const size_t count = static_cast<size_t>(total_values);
  std::string payload(kPlanes * count, '\0');
  size_t position = 0;
  for (const PreparedSequence& sequence : data.sequences) {
    const MotionFrames& frames = sequence.normalized;
    const int64_t frame_count = frames.frame_count();
    for (int d = 0; d < dims; ++d) {
      int32_t previous = 0;
      for (int64_t i = 0; i < frame_count; ++i) {
        const int32_t level = static_cast<int32_t>(std::lround(frames.frame(i)[d] * kLevelsPerStd));
        const uint32_t code = zigzag(level - previous);
        previous = level;
        for (size_t plane = 0; plane < kPlanes; ++plane) {
          payload[plane * count + position] = static_cast<char>((code >> (8 * plane)) & 0xFF);
        }
        ++position;
      }
    }
  }

  uLongf compressed_size = compressBound(static_cast<uLong>(payload.size()));
  std::string compressed(compressed_size, '\0');
  const int status = compress2(reinterpret_cast<Bytef*>(compressed.data()), &compressed_size,
                               reinterpret_cast<const Bytef*>(payload.data()),
                               static_cast<uLong>(payload.size()), 6);
  if (status != Z_OK) {
    throw std::runtime_error(path + ": zlib compression failed with code " + std::to_string(status));
  }
  compressed.resize(compressed_size);
  const uint32_t crc = static_cast<uint32_t>(
      crc32_z(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(compressed.data()), compressed.size()));

  const std::string header_text = header.dump();
  std::string file(kMagic, sizeof(kMagic));
  put_u32(file, kVersion);
  put_u64(file, header_text.size());
  file += header_text;
  put_u64(file, payload.size());
  put_u64(file, compressed.size());
  put_u32(file, crc);
  file += compressed;
  write_file_atomically(path, file);
}

namespace {

std::vector<std::string> string_list(const json& header, const char* field, const std::string& path) {
  if (!header.contains(field) || !header[field].is_array()) {
    throw InputError(path + ": header field \"" + field + "\" is missing or not an array");
  }
  std::vector<std::string> values;
  for (const json& value : header[field]) {
    if (!value.is_string()) {
      throw InputError(path + ": header field \"" + field + "\" holds " + value.dump() + ", expected strings");
    }
    values.push_back(value.get<std::string>());
  }
  return values;
}

int64_t integer_field(const json& object, const char* field, const std::string& where) {
  if (!object.contains(field) || !object[field].is_number_integer()) {
    throw InputError(where + ": field \"" + field + "\" is missing or not an integer");
  }
  return object[field].get<int64_t>();
}

}  // namespace

PreparedDataset load_prepared_dataset(const std::string& path) {
  const std::string bytes = read_whole_file(path);
  Reader reader(bytes, path);
  if (std::memcmp(reader.take(sizeof(kMagic), "magic"), kMagic, sizeof(kMagic)) != 0) {
    throw InputError(path + ": not a prepared data set (wrong magic bytes), expected a file "
                     "written by save_prepared_dataset");
  }
  const uint32_t version = reader.u32("version");
  if (version != kVersion) {
    throw InputError(path + ": prepared data set version " + std::to_string(version) +
                     " is not supported, expected " + std::to_string(kVersion));
  }
  const uint64_t header_size = reader.u64("header length");
  const char* header_bytes = reader.take(header_size, "header");
  json header;
  try {
    header = json::parse(header_bytes, header_bytes + header_size);
  } catch (const json::parse_error& error) {
    throw InputError(path + ": corrupt header: " + error.what());
  }
  if (!header.is_object()) throw InputError(path + ": corrupt header: expected a JSON object");

  PreparedDataset data;
  if (!header.contains("normalization")) throw InputError(path + ": header field \"normalization\" is missing");
  data.normalization = PoseNormalization::from_json_text(header["normalization"].dump(), path + " normalization");
  data.train_subjects = string_list(header, "train_subjects", path);
  data.test_subjects = string_list(header, "test_subjects", path);
  data.frame_rate = static_cast<int>(integer_field(header, "frame_rate", path + " header"));
  const int64_t dims = integer_field(header, "dims", path + " header");
  if (dims != data.normalization.dims()) {
    throw InputError(path + ": header field \"dims\" is " + std::to_string(dims) + ", expected " +
                     std::to_string(data.normalization.dims()) + " (the normalization's kept columns)");
  }
  if (header.contains("skeleton")) {
    data.skeleton = Skeleton::from_json_text(header["skeleton"].dump(), path + " skeleton");
  }
  if (header.contains("bvh_folder")) {
    if (!header["bvh_folder"].is_string()) throw InputError(path + ": header field \"bvh_folder\" is not a string");
    data.rig_folder = header["bvh_folder"].get<std::string>();
  }
  if (3 + 3 * data.skeleton.joint_count() != data.normalization.input_columns()) {
    throw InputError(path + ": the skeleton \"" + data.skeleton.name + "\" has " +
                     std::to_string(data.skeleton.joint_count()) + " joints, so motions of " +
                     std::to_string(3 + 3 * data.skeleton.joint_count()) + " columns, but the normalization has " +
                     std::to_string(data.normalization.input_columns()));
  }
  if (!header.contains("levels_per_std") || !header["levels_per_std"].is_number() ||
      header["levels_per_std"].get<double>() != kLevelsPerStd) {
    throw InputError(path + ": header field \"levels_per_std\" is missing or not " +
                     std::to_string(kLevelsPerStd));
  }
  if (!header.contains("sequences") || !header["sequences"].is_array()) {
    throw InputError(path + ": header field \"sequences\" is missing or not an array");
  }
  uint64_t total_values = 0;
  std::vector<int64_t> frame_counts;
  for (const json& entry : header["sequences"]) {
    const std::string where = path + " sequence " + std::to_string(data.sequences.size());
    if (!entry.is_object() || !entry.contains("subject") || !entry["subject"].is_string() ||
        !entry.contains("action") || !entry["action"].is_string()) {
      throw InputError(where + ": expected an object with string fields \"subject\" and \"action\"");
    }
    PreparedSequence sequence;
    sequence.subject = entry["subject"].get<std::string>();
    sequence.action = entry["action"].get<std::string>();
    sequence.take = static_cast<int>(integer_field(entry, "take", where));
    sequence.phase = static_cast<int>(integer_field(entry, "phase", where));
    const int64_t frames = integer_field(entry, "frames", where);
    if (frames < 0 || static_cast<uint64_t>(frames) > (uint64_t{1} << 40) / static_cast<uint64_t>(dims)) {
      throw InputError(where + ": field \"frames\" is " + std::to_string(frames) + ", expected a frame count");
    }
    sequence.normalized.columns = static_cast<int>(dims);
    frame_counts.push_back(frames);
    total_values += static_cast<uint64_t>(frames) * static_cast<uint64_t>(dims);
    data.sequences.push_back(std::move(sequence));
  }

  const uint64_t payload_size = reader.u64("payload length");
  const uint64_t compressed_size = reader.u64("compressed length");
  const uint32_t expected_crc = reader.u32("checksum");
  if (payload_size != kPlanes * total_values) {
    throw InputError(path + ": payload length " + std::to_string(payload_size) + " bytes, expected " +
                     std::to_string(kPlanes * total_values) + " for the sequences in the header");
  }
  const char* compressed = reader.take(compressed_size, "compressed payload");
  if (reader.remaining() != 0) {
    throw InputError(path + ": " + std::to_string(reader.remaining()) +
                     " unexpected bytes after the payload");
  }
  const uint32_t crc = static_cast<uint32_t>(
      crc32_z(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(compressed), compressed_size));
  if (crc != expected_crc) throw InputError(path + ": corrupt file: payload checksum mismatch");

  std::string payload(payload_size, '\0');
  uLongf inflated = static_cast<uLongf>(payload_size);
  const int status = uncompress(reinterpret_cast<Bytef*>(payload.data()), &inflated,
                                reinterpret_cast<const Bytef*>(compressed), static_cast<uLong>(compressed_size));
  if (status != Z_OK || inflated != payload_size) {
    throw InputError(path + ": corrupt file: payload does not decompress (zlib code " +
                     std::to_string(status) + ")");
  }

  const size_t count = static_cast<size_t>(total_values);
  const unsigned char* planes = reinterpret_cast<const unsigned char*>(payload.data());
  const float step = static_cast<float>(1.0 / kLevelsPerStd);
  size_t position = 0;
  for (size_t s = 0; s < data.sequences.size(); ++s) {
    MotionFrames& frames = data.sequences[s].normalized;
    const int64_t frame_count = frame_counts[s];
    frames.values.resize(static_cast<size_t>(frame_count * dims));
    for (int64_t d = 0; d < dims; ++d) {
      // Unsigned arithmetic: a corrupt payload that passed the CRC by chance
      // must not cause signed overflow.
      uint32_t level = 0;
      for (int64_t i = 0; i < frame_count; ++i) {
        uint32_t code = 0;
        for (size_t plane = 0; plane < kPlanes; ++plane) {
          code |= static_cast<uint32_t>(planes[plane * count + position]) << (8 * plane);
        }
        ++position;
        level += unzigzag(code);
        frames.values[static_cast<size_t>(i * dims + d)] = static_cast<float>(static_cast<int32_t>(level)) * step;
      }
    }
  }
  return data;
}

}  // namespace mm
