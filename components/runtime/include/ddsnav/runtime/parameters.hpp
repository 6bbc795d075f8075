// Component parameters: a YAML file (--config) plus `--param key=value` overrides, read with type checks.
//
//   Parameters p = Parameters::load("configs/mapper.yaml", {"resolution=0.05", "octree.max_range=30"});
//   double res = p.declare<double>("resolution", 0.1, {.above = 0, .unit = "m", .doc = "leaf size"});
//   p.rejectUndeclared();  // a typo in a key is an error, not a silently ignored setting
//
// A descriptor (ParamSpec) says once what a value may be: the range is checked where the value enters
// (the error names the parameter, its source and the range), and the same text documents it
// (describeTable(), printed by `ddsnav <component> --describe`, from which docs/parameters.md is made).
//
// Nested YAML maps are addressed with dots ("octree.max_range"). Every error names the parameter and
// where its value came from, and says what was expected.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <concepts>
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

// What a parameter may be, declared once beside its default. Bounds apply to numbers (integers are compared
// as numbers too): `min`/`max` are inclusive, `above`/`below` exclusive. `choices` lists the accepted
// strings. Aggregate, for designated initializers: {.min = 0, .max = 100, .unit = "Hz", .doc = "..."}.
struct ParamSpec {
  std::optional<double> min = std::nullopt;
  std::optional<double> above = std::nullopt;
  std::optional<double> max = std::nullopt;
  std::optional<double> below = std::nullopt;
  std::string unit = {};
  std::string doc = {};
  std::vector<std::string> choices = {};
};

// One declared parameter as --describe shows it.
struct ParamDescription {
  std::string key;
  std::string type;          // "number", "integer", "bool", "string", "list"
  std::string default_text;  // "(required)" for require(), "(see description)" for declareOptional()
  ParamSpec spec;
};

class Parameters {
 public:
  Parameters() = default;

  // No values, and require() answers a default-constructed value instead of failing: for --describe, which
  // runs a component's declarations to list them without starting anything.
  static Parameters describing() {
    Parameters p;
    p.describing_ = true;
    return p;
  }

  // file may be empty (no file). Throws ParameterError for an unreadable/invalid file or a bad override.
  static Parameters load(const std::string& file, const std::vector<std::string>& overrides);

  // The value of `key` converted to T, or `fallback` when not given. Records the key as declared.
  template <class T>
  T declare(const std::string& key, const T& fallback) {
    return declare<T>(key, fallback, ParamSpec{});
  }
  // The older form: a description only. (A template, so that a braced descriptor never converts to it.)
  template <class T, class Description>
    requires std::convertible_to<const Description&, std::string>
  T declare(const std::string& key, const T& fallback, const Description& description) {
    return declare<T>(key, fallback, ParamSpec{.doc = std::string(description)});
  }

  // The same with a descriptor: the value (given or default) must satisfy spec, else ParameterError.
  template <class T>
  T declare(const std::string& key, const T& fallback, const ParamSpec& spec) {
    record<T>(key, formatValue(fallback), spec);
    std::optional<T> v = get<T>(key, spec.doc);
    if (v) check(key, *v, spec);
    return v ? *v : fallback;
  }

  // A parameter whose default is not a fixed value (it depends on the scenario, say): nullopt when not
  // given; spec.doc says what the default is.
  template <class T>
  std::optional<T> declareOptional(const std::string& key, const ParamSpec& spec) {
    record<T>(key, "(see description)", spec);
    std::optional<T> v = get<T>(key, spec.doc);
    if (v) check(key, *v, spec);
    return v;
  }

  // Like declare, but a missing value is an error.
  template <class T>
  T require(const std::string& key) {
    return require<T>(key, ParamSpec{});
  }
  template <class T, class Description>
    requires std::convertible_to<const Description&, std::string>
  T require(const std::string& key, const Description& description) {
    return require<T>(key, ParamSpec{.doc = std::string(description)});
  }
  template <class T>
  T require(const std::string& key, const ParamSpec& spec) {
    record<T>(key, "(required)", spec);
    std::optional<T> v = get<T>(key, spec.doc);
    if (!v && describing_) return T{};
    if (!v) throw ParameterError("missing required parameter '" + key + "'" + describe(spec.doc) +
                                 ": set it in the config file or with --param " + key + "=...");
    check(key, *v, spec);
    return *v;
  }

  // Every parameter declared with a descriptor so far, in declaration order.
  const std::vector<ParamDescription>& descriptions() const { return descriptions_; }
  // Those as a Markdown table (parameter | type | default | range | unit | description).
  std::string describeTable() const;

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
  void record(const std::string& key, std::string default_text, const ParamSpec& spec) {
    for (const auto& d : descriptions_)
      if (d.key == key) return;  // declared twice (e.g. a shared seed): the first declaration describes it
    std::string type;
    if constexpr (std::is_same_v<T, bool>) type = "bool";
    else if constexpr (std::is_integral_v<T>) type = "integer";
    else if constexpr (std::is_floating_point_v<T>) type = "number";
    else if constexpr (std::is_same_v<T, std::string>) type = "string";
    else type = "list";
    descriptions_.push_back({key, std::move(type), std::move(default_text), spec});
  }

  template <class T>
  void check(const std::string& key, const T& value, const ParamSpec& spec) const {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      const double v = static_cast<double>(value);
      const bool ok = (!spec.min || v >= *spec.min) && (!spec.above || v > *spec.above) && (!spec.max || v <= *spec.max) &&
                      (!spec.below || v < *spec.below);
      if (!ok) throw ParameterError(where(key) + ": expected " + rangeText(spec) + ", got " + formatValue(value));
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (spec.choices.empty()) return;
      for (const auto& c : spec.choices)
        if (c == value) return;
      throw ParameterError(where(key) + ": expected " + rangeText(spec) + ", got '" + value + "'");
    }
  }

 public:
  // "[0, 100] Hz", "> 0 s", "one of: system, topic"; empty when unconstrained.
  static std::string rangeText(const ParamSpec& spec);
  static std::string formatValue(double v);
  static std::string formatValue(float v) { return formatValue(static_cast<double>(v)); }
  static std::string formatValue(bool v) { return v ? "true" : "false"; }
  static std::string formatValue(const std::string& v) { return v.empty() ? "\"\"" : v; }
  template <class T>
  static std::string formatValue(const T& v) {
    if constexpr (std::is_integral_v<T>) return std::to_string(v);
    else {
      std::string out = "[";
      for (const auto& e : v) out += (out.size() > 1 ? ", " : "") + formatValue(e);
      return out + "]";
    }
  }

 private:
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
  std::vector<ParamDescription> descriptions_;
  bool describing_ = false;
};

}  // namespace ddsnav::runtime
