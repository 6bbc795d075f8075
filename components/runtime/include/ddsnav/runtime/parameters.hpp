// Component parameters: a YAML file (--config) plus `--param key=value` overrides, read with type checks.
//
//   Parameters p = Parameters::load("configs/mapper.yaml", {"resolution=0.05", "octree.max_range=30"});
//   double res = p.declare<double>("resolution", 0.1, "leaf size, m");
//   p.rejectUndeclared();  // a typo in a key is an error, not a silently ignored setting
//
// Nested YAML maps are addressed with dots ("octree.max_range"). Every error names the parameter and
// where its value came from, and says what was expected.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace ddsnav::runtime {

class ParameterError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Parameters {
 public:
  Parameters() = default;

  // file may be empty (no file). Throws ParameterError for an unreadable/invalid file or a bad override.
  static Parameters load(const std::string& file, const std::vector<std::string>& overrides);

  // The value of `key` converted to T, or `fallback` when not given. Records the key as declared.
  template <class T>
  T declare(const std::string& key, const T& fallback, const std::string& description = {}) {
    std::optional<T> v = get<T>(key, description);
    return v ? *v : fallback;
  }

  // Like declare, but a missing value is an error.
  template <class T>
  T require(const std::string& key, const std::string& description = {}) {
    std::optional<T> v = get<T>(key, description);
    if (!v) throw ParameterError("missing required parameter '" + key + "'" + describe(description) +
                                 ": set it in the config file or with --param " + key + "=...");
    return *v;
  }

  bool has(const std::string& key) const { return values_.count(key) != 0; }

  // Throws ParameterError listing every given key that no declare/require asked for.
  void rejectUndeclared() const;

  // key -> source, e.g. "configs/mapper.yaml" or "--param"; for logging what was used.
  const std::map<std::string, std::string>& sources() const { return sources_; }

 private:
  template <class T>
  std::optional<T> get(const std::string& key, const std::string& description) {
    declared_.insert(key);
    auto it = values_.find(key);
    if (it == values_.end()) return std::nullopt;
    const YAML::Node& node = it->second;
    try {
      if constexpr (std::is_same_v<T, std::string>) {
        if (!node.IsScalar()) throw YAML::BadConversion(node.Mark());
      }
      T value = node.as<T>();
      if constexpr (std::is_floating_point_v<T>) {
        if (!std::isfinite(value)) throw ParameterError(where(key) + ": expected a finite number, got " + text(node));
      }
      if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
        // yaml-cpp reads "1.5" as an int failure but accepts "1e3" oddly; insist on plain digits.
        const std::string& s = node.Scalar();
        if (s.find_first_not_of("+-0123456789") != std::string::npos) throw YAML::BadConversion(node.Mark());
      }
      return value;
    } catch (const YAML::Exception&) {
      throw ParameterError(where(key) + describe(description) + ": expected " + typeName<T>() + ", got " +
                           text(node));
    }
  }

  template <class T>
  static std::string typeName() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_integral_v<T>) return "an integer";
    else if constexpr (std::is_floating_point_v<T>) return "a number";
    else if constexpr (std::is_same_v<T, std::string>) return "a string";
    else return "a list or map of the right element type";
  }
  static std::string describe(const std::string& d) { return d.empty() ? "" : " (" + d + ")"; }
  static std::string text(const YAML::Node& node);
  std::string where(const std::string& key) const;

  void set(const std::string& key, const YAML::Node& value, const std::string& source);
  void flatten(const YAML::Node& node, const std::string& prefix, const std::string& source);

  std::map<std::string, YAML::Node> values_;
  std::map<std::string, std::string> sources_;
  std::set<std::string> declared_;
};

}  // namespace ddsnav::runtime
