#include <ddsnav/runtime/parameters.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>

namespace ddsnav::runtime {

Parameters Parameters::load(const std::string& file, const std::vector<std::string>& overrides) {
  Parameters p;
  if (!file.empty()) {
    std::ifstream in(file);
    if (!in) throw ParameterError("cannot read config file '" + file + "'");
    YAML::Node root;
    try {
      root = YAML::Load(in);
    } catch (const YAML::Exception& e) {
      throw ParameterError("config file '" + file + "' line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
    }
    if (root.IsDefined() && !root.IsNull()) {
      if (!root.IsMap()) throw ParameterError("config file '" + file + "': expected a map of parameters at the top");
      p.flatten(root, "", file);
    }
  }
  for (const std::string& o : overrides) {
    auto eq = o.find('=');
    if (eq == std::string::npos || eq == 0)
      throw ParameterError("--param '" + o + "': expected key=value, e.g. --param resolution=0.05");
    std::string key = o.substr(0, eq);
    std::string value = o.substr(eq + 1);
    YAML::Node node;
    try {
      node = YAML::Load(value);  // so that lists ("[1, 2]") and typed scalars work like in the file
    } catch (const YAML::Exception& e) {
      throw ParameterError("--param " + key + ": cannot parse value '" + value + "': " + e.msg);
    }
    if (!node.IsDefined() || node.IsNull()) node = YAML::Node(value);
    p.set(key, node, "--param");
  }
  return p;
}

void Parameters::flatten(const YAML::Node& node, const std::string& prefix, const std::string& source) {
  for (const auto& kv : node) {
    // YAML allows a list or a map as a key ("? [a, b]: 1"); a parameter name is text.
    if (!kv.first.IsScalar())
      throw ParameterError("config file '" + source + "' line " + std::to_string(kv.first.Mark().line + 1) + ": a key " +
                           (prefix.empty() ? std::string("at the top") : "under '" + prefix + "'") + " is a " +
                           (kv.first.IsMap() ? "map" : kv.first.IsSequence() ? "list" : "null") +
                           ", expected a parameter name");
    std::string key = prefix.empty() ? kv.first.Scalar() : prefix + "." + kv.first.Scalar();
    if (kv.second.IsMap())
      flatten(kv.second, key, source);
    else
      set(key, kv.second, source);
  }
}

void Parameters::set(const std::string& key, const YAML::Node& value, const std::string& source) {
  values_[key] = value;
  sources_[key] = source;
}

void Parameters::rejectUndeclared() const {
  std::string unknown;
  for (const auto& [key, source] : sources_)
    if (declared_.count(key) == 0) unknown += (unknown.empty() ? "" : ", ") + key + " (" + source + ")";
  if (unknown.empty()) return;
  std::string known;
  for (const std::string& k : declared_) known += (known.empty() ? "" : ", ") + k;
  throw ParameterError("unknown parameter(s): " + unknown + "; this component takes: " +
                       (known.empty() ? "none" : known));
}

std::string Parameters::text(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a map";
  return "nothing";
}

std::string Parameters::where(const std::string& key) const {
  auto it = sources_.find(key);
  return "parameter '" + key + "'" + (it == sources_.end() ? "" : " (from " + it->second + ")");
}

}  // namespace ddsnav::runtime

namespace ddsnav::runtime {

std::string Parameters::formatValue(double v) {
  // The shortest text that reads back as the same double (0.1, not 0.10000000000000001).
  char buffer[32];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, v);
    if (std::strtod(buffer, nullptr) == v) break;
  }
  return buffer;
}

std::string Parameters::rangeText(const ParamSpec& spec) {
  if (!spec.choices.empty()) {
    std::string out = "one of: ";
    for (std::size_t i = 0; i < spec.choices.size(); ++i) out += (i ? ", " : "") + spec.choices[i];
    return out;
  }
  const bool has_low = spec.min || spec.above, has_high = spec.max || spec.below;
  const std::string unit = spec.unit.empty() ? "" : " " + spec.unit;
  const auto low = [&] { return formatValue(spec.min ? *spec.min : *spec.above); };
  const auto high = [&] { return formatValue(spec.max ? *spec.max : *spec.below); };
  if (has_low && has_high)
    return std::string(spec.min ? "[" : "(") + low() + ", " + high() + (spec.max ? "]" : ")") + unit;
  if (has_low) return std::string(spec.min ? ">= " : "> ") + low() + unit;
  if (has_high) return std::string(spec.max ? "<= " : "< ") + high() + unit;
  return "";
}

std::string Parameters::describeTable() const {
  std::string out = "| parameter | type | default | range | unit | description |\n|---|---|---|---|---|---|\n";
  for (const auto& d : descriptions_) {
    std::string range = rangeText(d.spec);
    // The unit has its own column: keep the range to the bounds.
    if (!d.spec.unit.empty() && range.size() > d.spec.unit.size() + 1 &&
        range.compare(range.size() - d.spec.unit.size() - 1, std::string::npos, " " + d.spec.unit) == 0)
      range.resize(range.size() - d.spec.unit.size() - 1);
    std::string doc = d.spec.doc;
    for (auto& c : doc)
      if (c == '|') c = '/';
    out += "| `" + d.key + "` | " + d.type + " | " + d.default_text + " | " + range + " | " + d.spec.unit + " | " + doc + " |\n";
  }
  return out;
}

}  // namespace ddsnav::runtime
