#include "format/skeleton.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <nlohmann/json.hpp>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "format/json_text.h"

namespace mm {

int Skeleton::joint_count() const { return static_cast<int>(joints.size()); }

namespace {

using nlohmann::json;

std::string joint_label(const std::string& source, size_t index, const json& entry) {
  std::string label = source + ": joint " + std::to_string(index);
  if (entry.is_object() && entry.contains("name") && entry["name"].is_string()) {
    label += " (\"" + entry["name"].get<std::string>() + "\")";
  }
  return label;
}

int integer_field(const json& entry, const char* field, const std::string& label) {
  if (!entry.contains(field)) throw InputError(label + ": field \"" + field + "\" is missing");
  const json& value = entry[field];
  if (!value.is_number_integer()) {
    throw InputError(label + ": field \"" + field + "\" is " + value.dump() +
                     ", expected an integer");
  }
  return value.get<int>();
}

bool is_bvh_channel_name(const std::string& name) {
  static const char* const kNames[] = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"};
  for (const char* known : kNames) {
    if (name == known) return true;
  }
  return false;
}

// The "bvh" object of a skeleton's JSON, checked against its joints.
BvhLayout parse_bvh_layout(const json& object, const Skeleton& skeleton, const std::string& source) {
  const std::string label = source + ": field \"bvh\"";
  if (!object.is_object()) throw InputError(label + " is " + object.dump() + ", expected a JSON object");
  BvhLayout layout;
  if (!object.contains("millimetres_per_unit") || !object["millimetres_per_unit"].is_number() ||
      !std::isfinite(object["millimetres_per_unit"].get<double>()) ||
      object["millimetres_per_unit"].get<double>() <= 0 || object["millimetres_per_unit"].get<double>() > 1e6) {
    throw InputError(label + ": \"millimetres_per_unit\" is " +
                     (object.contains("millimetres_per_unit") ? object["millimetres_per_unit"].dump() : "missing") +
                     ", expected a number in (0, 1e6]");
  }
  layout.millimetres_per_unit = object["millimetres_per_unit"].get<double>();
  if (!object.contains("joints") || !object["joints"].is_array() ||
      object["joints"].size() != skeleton.joints.size()) {
    throw InputError(label + ": \"joints\" is missing or not an array of " + std::to_string(skeleton.joints.size()) +
                     " entries, one a joint");
  }
  std::vector<bool> has_child(skeleton.joints.size(), false);
  for (const Joint& joint : skeleton.joints) {
    if (joint.parent >= 0) has_child[joint.parent] = true;
  }
  for (size_t j = 0; j < skeleton.joints.size(); ++j) {
    const json& entry = object["joints"][j];
    const std::string at = label + " joint " + std::to_string(j) + " (\"" + skeleton.joints[j].name + "\")";
    if (!entry.is_object() || !entry.contains("channels") || !entry["channels"].is_array() ||
        !entry.contains("end_site") || !entry["end_site"].is_boolean()) {
      throw InputError(at + " is " + entry.dump() + ", expected {\"channels\": [...], \"end_site\": true or false}");
    }
    std::vector<std::string> channels;
    for (const json& channel : entry["channels"]) {
      if (!channel.is_string() || !is_bvh_channel_name(channel.get<std::string>())) {
        throw InputError(at + ": channel " + channel.dump() +
                         ", expected one of Xposition Yposition Zposition Xrotation Yrotation Zrotation");
      }
      if (std::find(channels.begin(), channels.end(), channel.get<std::string>()) != channels.end()) {
        throw InputError(at + ": channel " + channel.dump() + " appears twice");
      }
      channels.push_back(channel.get<std::string>());
    }
    if (channels.size() > 6) throw InputError(at + ": " + std::to_string(channels.size()) + " channels, expected 0 to 6");
    const bool end_site = entry["end_site"].get<bool>();
    if (end_site && (!channels.empty() || has_child[j])) {
      throw InputError(at + ": an End Site with " + (has_child[j] ? "children" : "channels") +
                       ", expected a leaf without channels");
    }
    layout.channels.push_back(std::move(channels));
    layout.end_site.push_back(end_site);
  }
  return layout;
}

}  // namespace

Skeleton Skeleton::from_json_text(const std::string& text, const std::string& source_name) {
  const json document = parse_json_text(text, source_name);
  if (!document.is_object()) throw InputError(source_name + ": expected a JSON object");
  if (!document.contains("name") || !document["name"].is_string()) {
    throw InputError(source_name + ": field \"name\" is missing or not a string");
  }
  if (!document.contains("joints") || !document["joints"].is_array() || document["joints"].empty()) {
    throw InputError(source_name + ": field \"joints\" is missing or not a non-empty array");
  }

  Skeleton skeleton;
  skeleton.name = document["name"].get<std::string>();
  std::set<std::string> names;
  const json& entries = document["joints"];
  for (size_t i = 0; i < entries.size(); ++i) {
    const json& entry = entries[i];
    const std::string label = joint_label(source_name, i, entry);
    if (!entry.is_object()) throw InputError(label + ": expected a JSON object");

    const int index = integer_field(entry, "index", label);
    if (index != static_cast<int>(i)) {
      throw InputError(label + ": field \"index\" is " + std::to_string(index) +
                       ", expected its position " + std::to_string(i));
    }
    if (!entry.contains("name") || !entry["name"].is_string() ||
        entry["name"].get<std::string>().empty()) {
      throw InputError(label + ": field \"name\" is missing, empty or not a string");
    }
    Joint joint;
    joint.name = entry["name"].get<std::string>();
    if (!names.insert(joint.name).second) {
      throw InputError(label + ": field \"name\" repeats an earlier joint's name");
    }
    // Parents before children lets forward kinematics run in one pass.
    joint.parent = integer_field(entry, "parent", label);
    if (i == 0 && joint.parent != -1) {
      throw InputError(label + ": field \"parent\" is " + std::to_string(joint.parent) +
                       ", expected -1 for the root joint 0");
    }
    if (i > 0 && (joint.parent < 0 || joint.parent >= index)) {
      throw InputError(label + ": field \"parent\" is " + std::to_string(joint.parent) +
                       ", expected an index in [0, " + std::to_string(index) +
                       ") (parents precede children; only joint 0 is a root)");
    }
    if (!entry.contains("offset") || !entry["offset"].is_array() || entry["offset"].size() != 3) {
      throw InputError(label + ": field \"offset\" is " +
                       (entry.contains("offset") ? entry["offset"].dump() : std::string("missing")) +
                       ", expected an array of 3 numbers (mm)");
    }
    for (int axis = 0; axis < 3; ++axis) {
      const json& value = entry["offset"][static_cast<size_t>(axis)];
      if (!value.is_number() || !std::isfinite(value.get<double>())) {
        throw InputError(label + ": field \"offset\" element " + std::to_string(axis) + " is " +
                         value.dump() + ", expected a finite number (mm)");
      }
      joint.offset_mm[static_cast<size_t>(axis)] = value.get<double>();
    }
    skeleton.joints.push_back(std::move(joint));
  }
  if (document.contains("bvh")) skeleton.bvh = parse_bvh_layout(document["bvh"], skeleton, source_name);
  return skeleton;
}

std::string Skeleton::to_json_text() const {
  json document;
  document["name"] = name;
  document["units"] = "millimetres";
  json entries = json::array();
  for (size_t i = 0; i < joints.size(); ++i) {
    const Joint& joint = joints[i];
    entries.push_back({{"index", static_cast<int>(i)},
                       {"name", joint.name},
                       {"parent", joint.parent},
                       {"offset", {joint.offset_mm[0], joint.offset_mm[1], joint.offset_mm[2]}}});
  }
  document["joints"] = std::move(entries);
  if (bvh) {
    json layout_joints = json::array();
    for (size_t j = 0; j < bvh->channels.size(); ++j) {
      layout_joints.push_back({{"channels", bvh->channels[j]}, {"end_site", static_cast<bool>(bvh->end_site[j])}});
    }
    document["bvh"] = {{"millimetres_per_unit", bvh->millimetres_per_unit}, {"joints", std::move(layout_joints)}};
  }
  return document.dump(1);
}

Skeleton read_skeleton_file(const std::string& path) {
  return Skeleton::from_json_text(read_whole_file(path), path);
}

}  // namespace mm
