#include "ddsnav/launch/launch_config.hpp"

#include <ddsnav/runtime/topic_names.hpp>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

namespace ddsnav::launch {
namespace {

using runtime::topicNameError;

// Builds "file:line: key 'k': message" errors the way the scenario parser does.
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& key, const std::string& message) const {
    std::ostringstream out;
    out << source_;
    if (node.IsDefined() && node.Mark().line >= 0) out << ":" << node.Mark().line + 1;
    out << ": ";
    if (!key.empty()) out << "key '" << key << "': ";
    out << message;
    throw LaunchError(out.str());
  }

  // A mapping key as text. YAML allows a sequence or a mapping as a key (`? [a, b]`); no launch-file key
  // is one, so that is an error at the key's position rather than yaml-cpp's conversion error.
  std::string key(const YAML::Node& key_node, const std::string& where) const {
    if (!key_node.IsScalar())
      fail(key_node, where.empty() ? std::string("<key>") : where + ".<key>",
           std::string("expected a plain text key, got a ") + (key_node.IsSequence() ? "sequence" : key_node.IsMap() ? "mapping" : "null"));
    return key_node.Scalar();
  }

  // yaml-cpp keeps both entries of a repeated key and node["key"] finds the first, so a second
  // `params:` or `restart:` would be ignored without a word: refuse it, at the repeat's line.
  void uniqueKeys(const YAML::Node& map, const std::string& where) const {
    std::set<std::string> seen;
    for (const auto& entry : map) {
      const auto name = key(entry.first, where);
      if (!seen.insert(name).second) fail(entry.first, where.empty() ? name : where + "." + name, "duplicate key");
    }
  }

  void allowOnly(const YAML::Node& map, const std::set<std::string>& allowed, const std::string& where) const {
    if (!map.IsMap()) fail(map, where, "expected a mapping");
    uniqueKeys(map, where);
    for (const auto& entry : map) {
      const auto name = key(entry.first, where);
      if (!allowed.count(name)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(entry.first, name, "unknown key (expected one of: " + list + ")");
      }
    }
  }

  // A text value. A NUL would silently cut an argument or environment value at exec, so it is refused
  // everywhere; `single_line` values (names, commands, vendors) refuse every control character.
  std::string scalar(const YAML::Node& node, const std::string& key, bool single_line = false) const {
    if (!node.IsScalar()) fail(node, key, "expected a scalar value");
    const std::string& text = node.Scalar();
    for (size_t i = 0; i < text.size(); ++i) {
      const auto c = static_cast<unsigned char>(text[i]);
      if (c == 0 || ((c < 0x20 || c == 0x7f) && (single_line || (c != '\n' && c != '\t' && c != '\r'))))
        fail(node, key, "control character (byte " + std::to_string(c) + ") at offset " + std::to_string(i) + " is not allowed");
    }
    return text;
  }

  double duration(const YAML::Node& node, const DurationRange& range) const {
    double value = 0.0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, range.key, "expected a number of seconds in " + format(range.min_s) + ".." + format(range.max_s) + ", got '" +
                                (node.IsScalar() ? node.Scalar() : std::string("non-scalar")) + "'");
    }
    if (!(value >= range.min_s && value <= range.max_s))  // also refuses NaN and .inf
      fail(node, range.key, "must be in " + format(range.min_s) + ".." + format(range.max_s) + " s, got " +
                                (node.IsScalar() ? node.Scalar() : format(value)));
    return value;
  }

  template <class T>
  T number(const YAML::Node& node, const std::string& key, T min_value) const {
    T value{};
    try {
      value = node.as<T>();
    } catch (const YAML::Exception&) {
      fail(node, key, "expected a number, got '" + (node.IsScalar() ? node.Scalar() : std::string("non-scalar")) + "'");
    }
    if (!(value >= min_value)) fail(node, key, "must be >= " + std::to_string(min_value));
    return value;
  }

  static std::string format(double value) {
    std::ostringstream out;
    out << value;
    return out.str();
  }

  bool boolean(const YAML::Node& node, const std::string& key) const {
    try {
      return node.as<bool>();
    } catch (const YAML::Exception&) {
      fail(node, key, "expected true or false");
    }
  }

  std::vector<std::string> stringList(const YAML::Node& node, const std::string& key) const {
    if (!node.IsSequence()) fail(node, key, "expected a list");
    std::vector<std::string> out;
    for (const auto& item : node) out.push_back(scalar(item, key));
    return out;
  }

 private:
  std::string source_;
};

// Replaces ${name} with the variable's value; an unknown name is an error, "$$" is a literal "$".
std::string substitute(const std::string& text, const std::map<std::string, std::string>& variables,
                       const Reader& reader, const YAML::Node& node, const std::string& key) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '$' && i + 1 < text.size() && text[i + 1] == '$') {
      out += '$';
      ++i;
    } else if (text[i] == '$' && i + 1 < text.size() && text[i + 1] == '{') {
      const auto close = text.find('}', i + 2);
      if (close == std::string::npos) reader.fail(node, key, "unterminated ${ in '" + text + "'");
      const auto name = text.substr(i + 2, close - i - 2);
      const auto found = variables.find(name);
      if (found == variables.end()) reader.fail(node, key, "unknown variable ${" + name + "}");
      out += found->second;
      i = close;
    } else {
      out += text[i];
    }
    if (out.size() > kMaxExpandedTextBytes)
      reader.fail(node, key, "expands to more than " + std::to_string(kMaxExpandedTextBytes) + " bytes (kMaxExpandedTextBytes)");
  }
  return out;
}

// Orders processes so that each comes after everything it waits for; rejects unknown names and cycles.
std::vector<ProcessSpec> orderByDependencies(std::vector<ProcessSpec> processes, const std::string& source) {
  // `after:` may name a component of a container: it then waits for the container (ready once all are).
  std::map<std::string, std::string> container_of;
  for (const auto& p : processes)
    for (const auto& c : p.components) container_of[c.name] = p.name;
  for (auto& p : processes) {
    for (auto& dep : p.after)
      if (auto it = container_of.find(dep); it != container_of.end()) dep = it->second;
    std::erase(p.after, p.name);  // a component of this very container
  }
  std::map<std::string, const ProcessSpec*> by_name;
  for (const auto& p : processes) by_name[p.name] = &p;
  for (const auto& p : processes) {
    for (const auto& dep : p.after) {
      if (!by_name.count(dep)) throw LaunchError(source + ": process '" + p.name + "': 'after' names unknown process '" + dep + "'");
      if (!by_name.at(dep)->wait_ready)
        throw LaunchError(source + ": process '" + p.name + "': waits for '" + dep + "', which has wait_ready: false");
    }
  }
  std::vector<ProcessSpec> ordered;
  std::set<std::string> placed;
  while (ordered.size() < processes.size()) {
    bool progressed = false;
    for (const auto& p : processes) {
      if (placed.count(p.name)) continue;
      bool ready = true;
      for (const auto& dep : p.after) ready = ready && placed.count(dep);
      if (ready) {
        ordered.push_back(p);
        placed.insert(p.name);
        progressed = true;
      }
    }
    if (!progressed) {
      std::string cycle;
      for (const auto& p : processes)
        if (!placed.count(p.name)) cycle += (cycle.empty() ? "" : ", ") + p.name;
      throw LaunchError(source + ": 'after' dependencies form a cycle among: " + cycle);
    }
  }
  return ordered;
}

LaunchConfig loadLaunchConfigAt(const std::string& path, const std::map<std::string, std::string>& overrides, const std::string& set_flag,
                               const std::string& ns, int include_depth);

// The `variables:` block with `overrides` applied and every ${...} resolved (launch_dir built in).
std::map<std::string, std::string> resolveVariables(const YAML::Node& root, const Reader& reader, const std::string& source_name,
                                                    const std::map<std::string, std::string>& overrides, const std::string& set_flag) {
  struct {
    std::map<std::string, std::string> variables;
  } config;
  std::set<std::string> required_variables;
  if (const auto vars = root["variables"]) {
    if (!vars.IsMap()) reader.fail(vars, "variables", "expected a mapping of name: value");
    reader.uniqueKeys(vars, "variables");
    for (const auto& entry : vars) {
      const std::string name = reader.key(entry.first, "variables");
      // `name: ~` (or no value) declares a variable the user must give with --set.
      if (entry.second.IsNull()) {
        required_variables.insert(name);
        config.variables[name] = "";
      } else {
        config.variables[name] = reader.scalar(entry.second, "variables." + name);
      }
    }
  }
  // Built in: the launch file's own folder, so a launch file can name files beside it.
  if (!config.variables.count("launch_dir")) {
    std::error_code error;
    const auto dir = std::filesystem::absolute(std::filesystem::path(source_name), error).parent_path();
    config.variables["launch_dir"] = error ? std::string(".") : dir.lexically_normal().string();
  }
  for (const auto& [key, value] : overrides) {
    if (!config.variables.count(key))
      throw LaunchError(source_name + ": " + set_flag + " " + key + ": the launch file declares no variable '" + key + "'");
    if (value.find('\0') != std::string::npos) throw LaunchError(set_flag + " " + key + ": the value contains a NUL byte");
    config.variables[key] = value;
    required_variables.erase(key);
  }
  if (!required_variables.empty()) {
    const std::string& name = *required_variables.begin();
    reader.fail(root["variables"][name], "variables." + name, "required: give it with " + set_flag + " " + name + "=VALUE");
  }

  // Variables may use each other (and launch_dir): resolve each once, depth first, rejecting cycles,
  // chains deeper than kMaxVariableDepth and values that grow past kMaxExpandedTextBytes (a few lines
  // of `a: ${b}${b}`, `b: ${c}${c}`, ... would otherwise expand to gigabytes).
  {
    std::map<std::string, std::string> resolved;
    std::map<std::string, int> level;  // length of the longest ${...} chain below each variable
    std::set<std::string> in_progress;
    std::function<int(const std::string&, int)> resolve = [&](const std::string& key, int depth) -> int {
      if (resolved.count(key)) return level[key];
      const auto node = root["variables"] && root["variables"][key] ? root["variables"][key] : root;
      const std::string where = "variables." + key;
      const auto too_deep = [&] {
        reader.fail(node, where, "variables refer to each other more than " + std::to_string(kMaxVariableDepth) +
                                     " levels deep (kMaxVariableDepth)");
      };
      if (!in_progress.insert(key).second) reader.fail(node, where, "variables refer to each other in a cycle");
      if (depth > kMaxVariableDepth) too_deep();  // before the recursion gets deep, not after
      const std::string& raw = config.variables.at(key);
      int own = 0;
      for (size_t at = raw.find("${"); at != std::string::npos; at = raw.find("${", at + 2)) {
        const auto close = raw.find('}', at);
        const auto name = close == std::string::npos ? "" : raw.substr(at + 2, close - at - 2);
        if (config.variables.count(name)) own = std::max(own, 1 + resolve(name, depth + 1));
      }
      if (own > kMaxVariableDepth) too_deep();
      resolved[key] = substitute(raw, resolved, reader, node, where);
      level[key] = own;
      in_progress.erase(key);
      return own;
    };
    for (const auto& entry : config.variables) resolve(entry.first, 0);
    config.variables = std::move(resolved);
  }

  return config.variables;
}

std::string joinNamespace(const std::string& outer, const std::string& inner) {
  if (outer.empty()) return inner;
  if (inner.empty()) return outer;
  return outer + "/" + inner;
}

LaunchConfig parseLaunchRoot(const std::string& yaml_text, const std::string& source_name, const std::map<std::string, std::string>& overrides,
                             const std::string& set_flag, const std::string& ns, int include_depth);

// One `processes:` list: processes, groups and includes, names prefixed with the namespace.
void parseProcessList(const YAML::Node& list, const Reader& reader, const std::map<std::string, std::string>& variables,
                      const std::string& ns, const std::string& source_name, int include_depth, std::vector<ProcessSpec>& processes) {
  if (!list || !list.IsSequence() || list.size() == 0) reader.fail(list, "processes", "expected a non-empty list of processes");
  // Short names of this list, so that `after:` may name them without the namespace.
  std::set<std::string> local;
  for (const auto& node : list) {
    if (node.IsMap() && node["name"] && node["name"].IsScalar()) local.insert(node["name"].Scalar());
    if (node.IsMap() && node["container"] && node["container"].IsScalar()) local.insert(node["container"].Scalar());
    if (node.IsMap() && node["container"] && node["components"] && node["components"].IsSequence())
      for (const auto& c : node["components"])
        if (c.IsMap() && c["name"] && c["name"].IsScalar()) local.insert(c["name"].Scalar());
  }
  const auto qualified = [&](const std::string& name) { return ns.empty() ? name : ns + "/" + name; };
  const auto groupNamespace = [&](const YAML::Node& node) {
    if (!node["namespace"]) return ns;
    const std::string inner = substitute(reader.scalar(node["namespace"], "namespace", true), variables, reader, node["namespace"], "namespace");
    if (const auto error = topicNameError(inner); !error.empty()) reader.fail(node["namespace"], "namespace", "'" + inner + "' " + error);
    return joinNamespace(ns, inner);
  };
  for (const auto& node : list) {
    if (node.IsMap() && node["include"]) {
      reader.allowOnly(node, {"include", "namespace", "variables"}, "processes");
      if (include_depth >= kMaxIncludeDepth)
        reader.fail(node["include"], "include", "includes nested more than " + std::to_string(kMaxIncludeDepth) + " deep (kMaxIncludeDepth)");
      std::filesystem::path file = substitute(reader.scalar(node["include"], "include", true), variables, reader, node["include"], "include");
      if (file.is_relative()) file = std::filesystem::path(variables.at("launch_dir")) / file;
      std::map<std::string, std::string> given;
      if (const auto vars = node["variables"]) {
        if (!vars.IsMap()) reader.fail(vars, "variables", "expected a mapping of name: value");
        reader.uniqueKeys(vars, "variables");
        for (const auto& entry : vars) {
          const auto name = reader.key(entry.first, "variables");
          given[name] = substitute(reader.scalar(entry.second, "variables." + name), variables, reader, entry.second, "variables." + name);
        }
      }
      LaunchConfig included;
      try {
        included = loadLaunchConfigAt(file.lexically_normal().string(), given, "include variables:", groupNamespace(node), include_depth + 1);
      } catch (const LaunchError& e) {
        reader.fail(node["include"], "include", e.what());
      }
      for (auto& p : included.processes) {
        if (!p.dds && included.dds_given) p.dds = included.dds;  // the included file's default vendor
        processes.push_back(std::move(p));
      }
      continue;
    }
    if (node.IsMap() && node["processes"]) {
      reader.allowOnly(node, {"namespace", "processes"}, "processes");
      parseProcessList(node["processes"], reader, variables, groupNamespace(node), source_name, include_depth, processes);
      continue;
    }
    const auto parseParams = [&](const YAML::Node& params, std::map<std::string, std::string>& out) {
      if (!params.IsMap()) reader.fail(params, "params", "expected a mapping of parameter: value");
      reader.uniqueKeys(params, "params");
      for (const auto& entry : params) {
        const auto key = reader.key(entry.first, "params");
        if (key.empty() || key.find('=') != std::string::npos || key.find('\0') != std::string::npos)
          reader.fail(entry.first, "params." + key, "a parameter name must be non-empty and contain no '=' or NUL");
        out[key] = substitute(reader.scalar(entry.second, key), variables, reader, entry.second, key);
      }
    };
    const auto parseRemap = [&](const YAML::Node& remap, std::map<std::string, std::string>& out) {
      if (!remap.IsMap()) reader.fail(remap, "remap", "expected a mapping of from: to topic names");
      reader.uniqueKeys(remap, "remap");
      for (const auto& entry : remap) {
        const auto from = reader.key(entry.first, "remap");
        const auto to = substitute(reader.scalar(entry.second, "remap." + from, true), variables, reader, entry.second, "remap." + from);
        for (const auto& n : {from, to.empty() || to.front() != '/' ? to : to.substr(1)})
          if (const auto error = topicNameError(n); !error.empty()) reader.fail(entry.first, "remap." + from, "'" + n + "' " + error);
        if (from == "system/status") reader.fail(entry.first, "remap." + from, "system/status is never remapped");
        out[from] = to;
      }
    };
    const auto checkName = [&](const YAML::Node& name_node, const std::string& key) {
      std::string name = reader.scalar(name_node, key, true);
      if (name.empty() || name.size() > kMaxNameBytes)
        reader.fail(name_node, key, "must be 1.." + std::to_string(kMaxNameBytes) + " bytes long");
      name = qualified(name);
      for (const auto& p : processes) {
        if (p.name == name) reader.fail(name_node, key, "duplicate process name '" + name + "'");
        for (const auto& c : p.components)
          if (c.name == name) reader.fail(name_node, key, "duplicate name '" + name + "' (a component of container '" + p.name + "')");
      }
      return name;
    };
    const bool container = node.IsMap() && node["container"];
    reader.allowOnly(node,
                     container ? std::set<std::string>{"container", "components", "args", "dds", "after", "restart", "max_restarts",
                                                       "restart_window_s", "restart_delay_s", "max_restart_delay_s", "ready_timeout_s",
                                                       "liveness_timeout_s", "required", "namespace"}
                               : std::set<std::string>{"name", "command", "args", "dds", "params", "after", "wait_ready", "restart", "max_restarts",
                      "restart_window_s", "restart_delay_s", "max_restart_delay_s", "ready_timeout_s",
                      "liveness_timeout_s", "required", "namespace", "remap"},
                     "processes");
    ProcessSpec spec;
    if (container) {
      // One process, ddsnav-container, holding the listed components (runtime::runContainer).
      spec.name = checkName(node["container"], "container");
      spec.command = "ddsnav-container";
      const std::string ns = groupNamespace(node);
      const auto components = node["components"];
      if (!components || !components.IsSequence() || components.size() == 0)
        reader.fail(components ? components : node, "components", "container '" + spec.name + "' needs a non-empty list of components");
      for (const auto& c : components) {
        reader.allowOnly(c, {"name", "component", "args", "params", "namespace", "remap"}, "components");
        ComponentSpec component;
        if (!c["component"]) reader.fail(c, "component", "every component names its kind (component: planner)");
        component.component = substitute(reader.scalar(c["component"], "component", true), variables, reader, c["component"], "component");
        component.name = checkName(c["name"] ? c["name"] : c["component"], c["name"] ? "name" : "component");
        for (const auto& other : spec.components)
          if (other.name == component.name) reader.fail(c, "name", "duplicate component name '" + component.name + "'");
        if (c["namespace"]) {
          const std::string inner = substitute(reader.scalar(c["namespace"], "namespace", true), variables, reader, c["namespace"], "namespace");
          if (const auto error = topicNameError(inner); !error.empty()) reader.fail(c["namespace"], "namespace", "'" + inner + "' " + error);
          component.ns = joinNamespace(ns, inner);
        } else {
          component.ns = ns;
        }
        if (c["args"])
          for (const auto& arg : reader.stringList(c["args"], "args")) component.args.push_back(substitute(arg, variables, reader, c["args"], "args"));
        if (c["params"]) parseParams(c["params"], component.params);
        if (c["remap"]) parseRemap(c["remap"], component.remap);
        spec.components.push_back(std::move(component));
      }
    } else {
      if (!node["name"]) reader.fail(node, "name", "every process needs a name");
      spec.name = checkName(node["name"], "name");
      spec.ns = groupNamespace(node);
    }
    if (!container) {
      if (!node["command"]) reader.fail(node, "command", "process '" + spec.name + "' needs a command");
      spec.command = substitute(reader.scalar(node["command"], "command", true), variables, reader, node["command"], "command");
      if (spec.command.empty()) reader.fail(node["command"], "command", "process '" + spec.name + "': the command is empty");
      for (const char c : spec.command)  // a variable's value may bring one in
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
          reader.fail(node["command"], "command", "process '" + spec.name + "': control character in the expanded command");
    }
    if (node["args"])
      for (const auto& arg : reader.stringList(node["args"], "args"))
        spec.args.push_back(substitute(arg, variables, reader, node["args"], "args"));
    if (node["dds"]) spec.dds = reader.scalar(node["dds"], "dds", true);
    if (node["params"]) parseParams(node["params"], spec.params);
    if (node["after"])
      for (const auto& dep : reader.stringList(node["after"], "after")) spec.after.push_back(local.count(dep) ? qualified(dep) : dep);
    if (node["remap"]) parseRemap(node["remap"], spec.remap);
    if (node["wait_ready"]) spec.wait_ready = reader.boolean(node["wait_ready"], "wait_ready");
    if (node["restart"]) {
      try {
        spec.restart = parseRestartPolicy(reader.scalar(node["restart"], "restart"));
      } catch (const LaunchError& e) {
        reader.fail(node["restart"], "restart", e.what());
      }
    }
    if (node["max_restarts"]) {
      spec.max_restarts = reader.number<int>(node["max_restarts"], "max_restarts", 0);
      if (spec.max_restarts > kMaxRestartsLimit)
        reader.fail(node["max_restarts"], "max_restarts", "must be in 0.." + std::to_string(kMaxRestartsLimit));
    }
    if (node["restart_window_s"]) spec.restart_window_s = reader.duration(node["restart_window_s"], kRestartWindowRange);
    if (node["restart_delay_s"]) spec.restart_delay_s = reader.duration(node["restart_delay_s"], kRestartDelayRange);
    if (node["max_restart_delay_s"]) spec.max_restart_delay_s = reader.duration(node["max_restart_delay_s"], kMaxRestartDelayRange);
    if (spec.max_restart_delay_s < spec.restart_delay_s)
      reader.fail(node["max_restart_delay_s"] ? node["max_restart_delay_s"] : node["restart_delay_s"], "max_restart_delay_s",
                  "must be >= restart_delay_s (" + Reader::format(spec.restart_delay_s) + " s)");
    if (node["ready_timeout_s"]) spec.ready_timeout_s = reader.duration(node["ready_timeout_s"], kReadyTimeoutRange);
    if (node["liveness_timeout_s"]) {
      spec.liveness_timeout_s = reader.duration(node["liveness_timeout_s"], kLivenessTimeoutRange);
      if (node["wait_ready"] && !spec.wait_ready)
        reader.fail(node["liveness_timeout_s"], "liveness_timeout_s",
                    "needs heartbeats on system/status, which a process with wait_ready: false does not send");
    }
    if (node["required"]) spec.required = reader.boolean(node["required"], "required");
    processes.push_back(std::move(spec));
  }
}

}  // namespace

RestartPolicy parseRestartPolicy(const std::string& text) {
  if (text == "never" || text == "no") return RestartPolicy::Never;
  if (text == "on-failure") return RestartPolicy::OnFailure;
  if (text == "always") return RestartPolicy::Always;
  throw LaunchError("unknown restart policy '" + text + "' (expected never, on-failure or always)");
}

std::string toString(RestartPolicy policy) {
  switch (policy) {
    case RestartPolicy::Never: return "never";
    case RestartPolicy::OnFailure: return "on-failure";
    case RestartPolicy::Always: return "always";
  }
  return "?";
}

namespace {

LaunchConfig parseLaunchRoot(const std::string& yaml_text, const std::string& source_name, const std::map<std::string, std::string>& overrides,
                             const std::string& set_flag, const std::string& ns, int include_depth) {
  const Reader reader(source_name);
  if (yaml_text.size() > kMaxLaunchFileBytes)
    throw LaunchError(source_name + ": " + std::to_string(yaml_text.size()) + " bytes is larger than the limit of " +
                      std::to_string(kMaxLaunchFileBytes) + " bytes for a launch file (kMaxLaunchFileBytes)");
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw LaunchError(source_name + ":" + std::to_string(e.mark.line + 1) + ": invalid YAML: " + e.msg);
  }
  if (!root.IsMap()) throw LaunchError(source_name + ": expected a mapping at the top level");
  reader.allowOnly(root, {"name", "domain", "dds", "shutdown_timeout_s", "variables", "security", "network", "processes"}, "");

  LaunchConfig config;
  config.source = source_name;
  config.name = root["name"] ? reader.scalar(root["name"], "name", true) : source_name;
  if (root["domain"]) {
    config.domain = reader.number<int>(root["domain"], "domain", 0);
    if (*config.domain > 232) reader.fail(root["domain"], "domain", "must be in 0..232");
  }
  if (root["dds"]) {
    config.dds = reader.scalar(root["dds"], "dds", true);
    config.dds_given = true;
  }
  if (root["shutdown_timeout_s"]) config.shutdown_timeout_s = reader.duration(root["shutdown_timeout_s"], kShutdownTimeoutRange);
  config.variables = resolveVariables(root, reader, source_name, overrides, set_flag);
  // Relative to the launch file's folder, like every other path a launch file names.
  if (const auto node = root["security"]) {
    std::string dir = substitute(reader.scalar(node, "security", true), config.variables, reader, node, "security");
    if (dir.empty()) reader.fail(node, "security", "expected the directory made by `ddsnav security init`");
    if (std::filesystem::path(dir).is_relative()) dir = config.variables["launch_dir"] + "/" + dir;
    config.security = std::filesystem::path(dir).lexically_normal().string();
  }
  if (const auto node = root["network"]) {
    if (!node.IsMap()) reader.fail(node, "network", "expected a mapping with interface, peers, multicast");
    reader.allowOnly(node, {"interface", "peers", "multicast"}, "network");
    if (!node["interface"]) reader.fail(node, "network.interface", "required: the network interface to use, e.g. eth0");
    NetworkSpec network;
    network.interface = substitute(reader.scalar(node["interface"], "network.interface", true), config.variables, reader,
                                   node["interface"], "network.interface");
    if (network.interface.empty() || network.interface.find_first_of(" ,/") != std::string::npos)
      reader.fail(node["interface"], "network.interface", "expected an interface name such as eth0");
    if (node["peers"])
      for (const auto& peer : reader.stringList(node["peers"], "network.peers")) {
        std::string host = substitute(peer, config.variables, reader, node["peers"], "network.peers");
        if (host.empty() || host.find_first_of(" ,") != std::string::npos)
          reader.fail(node["peers"], "network.peers", "each peer is one host name or IPv4 address");
        network.peers.push_back(host);
      }
    if (node["multicast"]) network.multicast = reader.boolean(node["multicast"], "network.multicast");
    config.network = network;
  }
  std::vector<ProcessSpec> processes;
  parseProcessList(root["processes"], reader, config.variables, ns, source_name, include_depth, processes);
  if (processes.size() > kMaxProcesses)
    reader.fail(root["processes"], "processes", "more than " + std::to_string(kMaxProcesses) + " processes (kMaxProcesses)");
  std::set<std::string> names;
  for (const auto& p : processes)
    if (!names.insert(p.name).second) throw LaunchError(source_name + ": duplicate process name '" + p.name + "'");
  config.processes = std::move(processes);
  return config;
}

}  // namespace

LaunchConfig parseLaunchConfig(const std::string& yaml_text, const std::string& source_name,
                               const std::map<std::string, std::string>& overrides) {
  LaunchConfig config = parseLaunchRoot(yaml_text, source_name, overrides, "--set", "", 0);
  config.processes = orderByDependencies(std::move(config.processes), source_name);
  return config;
}

namespace {
LaunchConfig loadLaunchConfigAt(const std::string& path, const std::map<std::string, std::string>& overrides, const std::string& set_flag,
                               const std::string& ns, int include_depth) {
  // Size and kind first: a FIFO or device would block or never end, a huge file would be parsed whole.
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) throw LaunchError(path + ": cannot open launch file");
  if (!std::filesystem::is_regular_file(status)) throw LaunchError(path + ": not a regular file");
  const auto size = std::filesystem::file_size(path, error);
  if (error) throw LaunchError(path + ": cannot read launch file: " + error.message());
  if (size > kMaxLaunchFileBytes)
    throw LaunchError(path + ": " + std::to_string(size) + " bytes is larger than the limit of " +
                      std::to_string(kMaxLaunchFileBytes) + " bytes for a launch file (kMaxLaunchFileBytes)");
  std::ifstream in(path);
  if (!in) throw LaunchError(path + ": cannot open launch file");
  std::string text(kMaxLaunchFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  if (text.size() > kMaxLaunchFileBytes) throw LaunchError(path + ": grew past the launch file limit while being read");
  return parseLaunchRoot(text, path, overrides, set_flag, ns, include_depth);
}
}  // namespace

LaunchConfig loadLaunchConfig(const std::string& path, const std::map<std::string, std::string>& overrides) {
  LaunchConfig config = loadLaunchConfigAt(path, overrides, "--set", "", 0);
  config.processes = orderByDependencies(std::move(config.processes), path);
  return config;
}


}  // namespace ddsnav::launch
