// SPDX-License-Identifier: Apache-2.0
// model_difference (imm/pipeline/registry.hpp): whether two model files hold the same model.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "imm/io/container_file.hpp"
#include "imm/io/model_file.hpp"
#include "imm/pipeline/registry.hpp"

namespace imm::pipeline {
namespace {

// What a file's build and clock put in it, not its model.
bool circumstantial(const std::string& object, const std::string& attribute) {
  if (object == "/" && (attribute == "created_utc" || attribute == "trainer_version")) return true;
  return attribute.ends_with("seconds");
}

// Reals equal to within kModelRounding of `scale` (the largest magnitude they are part of).
constexpr double kModelRounding = 1e-6;
bool close(double a, double b, double scale) { return std::abs(a - b) <= kModelRounding * scale; }

std::string attribute_text(const io::Attribute& value) {
  if (const auto* text = std::get_if<std::string>(&value)) {
    std::string quoted(1, '\'');  // (not "'" + …: GCC 12 warns falsely on that form, bug 105329)
    quoted.append(text->substr(0, 40)).push_back('\'');
    return quoted;
  }
  if (const auto* integer = std::get_if<std::int64_t>(&value)) return std::to_string(*integer);
  return std::to_string(std::get<double>(value));
}

}  // namespace

ModelDifference model_difference(const std::filesystem::path& a, const std::filesystem::path& b) {
  using Kind = ModelDifference::Kind;
  const io::ContainerReader x(a, io::kModelFormat);
  const io::ContainerReader y(b, io::kModelFormat);
  const std::vector<std::string> objects = x.objects();
  if (objects != y.objects()) return {Kind::kStructure, "they hold different objects"};
  for (const std::string& object : objects) {
    if (x.kind(object) != y.kind(object))
      return {Kind::kValues, object + " is a group in one file only"};
    if (x.kind(object) == io::ObjectKind::kDataset) {
      const io::Array u = x.read(object);
      const io::Array v = y.read(object);
      if (u.shape != v.shape) return {Kind::kValues, object + " has another shape"};
      double scale = 0.0;
      for (std::size_t i = 0; i < u.values.size(); ++i) {
        scale = std::max({scale, std::abs(u.values[i]), std::abs(v.values[i])});
      }
      for (std::size_t i = 0; i < u.values.size(); ++i) {
        if (!close(u.values[i], v.values[i], scale)) {
          return {Kind::kValues, object + "[" + std::to_string(i) + "] is " +
                                     std::to_string(u.values[i]) + " against " +
                                     std::to_string(v.values[i])};
        }
      }
    }
    std::vector<std::string> names = x.attribute_names(object);
    if (names != y.attribute_names(object))
      return {Kind::kStructure, object + " has other attributes"};
    for (const std::string& name : names) {
      if (circumstantial(object, name)) continue;
      const std::optional<io::Attribute> u = x.attribute(object, name);
      const std::optional<io::Attribute> v = y.attribute(object, name);
      const auto* p = u ? std::get_if<double>(&*u) : nullptr;
      const auto* q = v ? std::get_if<double>(&*v) : nullptr;
      const bool same = p != nullptr && q != nullptr
                            ? close(*p, *q, std::max(std::abs(*p), std::abs(*q)))
                            : u == v;
      if (!same) {
        std::string text = object;
        text.append("@").append(name).append(" is ");
        text.append(u ? attribute_text(*u) : "absent").append(" against ");
        return {Kind::kValues, text.append(v ? attribute_text(*v) : "absent")};
      }
    }
  }
  return {};
}

}  // namespace imm::pipeline
