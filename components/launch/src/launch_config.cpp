#include "ddsnav/launch/launch_config.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

namespace ddsnav::launch {
namespace {

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

  // yaml-cpp keeps both entries of a repeated key and node["key"] finds the first, so a second
  // `params:` or `restart:` would be ignored without a word: refuse it, at the repeat's line.
  void uniqueKeys(const YAML::Node& map, const std::string& where) const {
    std::set<std::string> seen;
    for (const auto& entry : map) {
      const auto key = entry.first.as<std::string>();
      if (!seen.insert(key).second) fail(entry.first, where.empty() ? key : where + "." + key, "duplicate key");
    }
  }

  void allowOnly(const YAML::Node& map, const std::set<std::string>& allowed, const std::string& where) const {
    if (!map.IsMap()) fail(map, where, "expected a mapping");
    uniqueKeys(map, where);
    for (const auto& entry : map) {
      const auto key = entry.first.as<std::string>();
      if (!allowed.count(key)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(entry.first, key, "unknown key (expected one of: " + list + ")");
      }
    }
  }

  std::string scalar(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, key, "expected a scalar value");
    return node.Scalar();
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
  }
  return out;
}

// Orders processes so that each comes after everything it waits for; rejects unknown names and cycles.
std::vector<ProcessSpec> orderByDependencies(std::vector<ProcessSpec> processes, const std::string& source) {
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

LaunchConfig parseLaunchConfig(const std::string& yaml_text, const std::string& source_name,
                               const std::map<std::string, std::string>& overrides) {
  const Reader reader(source_name);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw LaunchError(source_name + ":" + std::to_string(e.mark.line + 1) + ": invalid YAML: " + e.msg);
  }
  if (!root.IsMap()) throw LaunchError(source_name + ": expected a mapping at the top level");
  reader.allowOnly(root, {"name", "domain", "dds", "shutdown_timeout_s", "variables", "processes"}, "");

  LaunchConfig config;
  config.source = source_name;
  config.name = root["name"] ? reader.scalar(root["name"], "name") : source_name;
  if (root["domain"]) {
    config.domain = reader.number<int>(root["domain"], "domain", 0);
    if (*config.domain > 232) reader.fail(root["domain"], "domain", "must be in 0..232");
  }
  if (root["dds"]) config.dds = reader.scalar(root["dds"], "dds");
  if (root["shutdown_timeout_s"])
    config.shutdown_timeout_s = reader.number<double>(root["shutdown_timeout_s"], "shutdown_timeout_s", 0.1);
  std::set<std::string> required_variables;
  if (const auto vars = root["variables"]) {
    if (!vars.IsMap()) reader.fail(vars, "variables", "expected a mapping of name: value");
    reader.uniqueKeys(vars, "variables");
    for (const auto& entry : vars) {
      const std::string name = entry.first.as<std::string>();
      // `name: ~` (or no value) declares a variable the user must give with --set.
      if (entry.second.IsNull()) {
        required_variables.insert(name);
        config.variables[name] = "";
      } else {
        config.variables[name] = reader.scalar(entry.second, name);
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
      throw LaunchError(source_name + ": --set " + key + ": the launch file declares no variable '" + key + "'");
    config.variables[key] = value;
    required_variables.erase(key);
  }
  if (!required_variables.empty()) {
    const std::string& name = *required_variables.begin();
    reader.fail(root["variables"][name], "variables." + name, "required: give it with --set " + name + "=VALUE");
  }

  // Variables may use each other (and launch_dir): resolve each once, depth first, rejecting cycles.
  {
    std::map<std::string, std::string> resolved;
    std::set<std::string> in_progress;
    std::function<void(const std::string&)> resolve = [&](const std::string& key) {
      if (resolved.count(key)) return;
      const auto node = root["variables"] && root["variables"][key] ? root["variables"][key] : root;
      if (!in_progress.insert(key).second) reader.fail(node, key, "variables refer to each other in a cycle");
      const std::string& raw = config.variables.at(key);
      for (size_t at = raw.find("${"); at != std::string::npos; at = raw.find("${", at + 2)) {
        const auto close = raw.find('}', at);
        const auto name = close == std::string::npos ? "" : raw.substr(at + 2, close - at - 2);
        if (config.variables.count(name)) resolve(name);
      }
      resolved[key] = substitute(raw, resolved, reader, node, key);
      in_progress.erase(key);
    };
    for (const auto& entry : config.variables) resolve(entry.first);
    config.variables = std::move(resolved);
  }

  const auto list = root["processes"];
  if (!list || !list.IsSequence() || list.size() == 0) reader.fail(root, "processes", "expected a non-empty list of processes");
  std::set<std::string> names;
  std::vector<ProcessSpec> processes;
  for (const auto& node : list) {
    reader.allowOnly(node,
                     {"name", "command", "args", "dds", "params", "after", "wait_ready", "restart", "max_restarts",
                      "ready_timeout_s", "required"},
                     "processes");
    ProcessSpec spec;
    if (!node["name"]) reader.fail(node, "name", "every process needs a name");
    spec.name = reader.scalar(node["name"], "name");
    if (!names.insert(spec.name).second) reader.fail(node["name"], "name", "duplicate process name '" + spec.name + "'");
    if (!node["command"]) reader.fail(node, "command", "process '" + spec.name + "' needs a command");
    spec.command = substitute(reader.scalar(node["command"], "command"), config.variables, reader, node["command"], "command");
    if (node["args"])
      for (const auto& arg : reader.stringList(node["args"], "args"))
        spec.args.push_back(substitute(arg, config.variables, reader, node["args"], "args"));
    if (node["dds"]) spec.dds = reader.scalar(node["dds"], "dds");
    if (const auto params = node["params"]) {
      if (!params.IsMap()) reader.fail(params, "params", "expected a mapping of parameter: value");
      reader.uniqueKeys(params, "params");
      for (const auto& entry : params) {
        const auto key = entry.first.as<std::string>();
        spec.params[key] = substitute(reader.scalar(entry.second, key), config.variables, reader, entry.second, key);
      }
    }
    if (node["after"]) spec.after = reader.stringList(node["after"], "after");
    if (node["wait_ready"]) spec.wait_ready = reader.boolean(node["wait_ready"], "wait_ready");
    if (node["restart"]) {
      try {
        spec.restart = parseRestartPolicy(reader.scalar(node["restart"], "restart"));
      } catch (const LaunchError& e) {
        reader.fail(node["restart"], "restart", e.what());
      }
    }
    if (node["max_restarts"]) spec.max_restarts = reader.number<int>(node["max_restarts"], "max_restarts", 0);
    if (node["ready_timeout_s"]) spec.ready_timeout_s = reader.number<double>(node["ready_timeout_s"], "ready_timeout_s", 0.1);
    if (node["required"]) spec.required = reader.boolean(node["required"], "required");
    processes.push_back(std::move(spec));
  }
  config.processes = orderByDependencies(std::move(processes), source_name);
  return config;
}

LaunchConfig loadLaunchConfig(const std::string& path, const std::map<std::string, std::string>& overrides) {
  std::ifstream in(path);
  if (!in) throw LaunchError(path + ": cannot open launch file");
  std::stringstream text;
  text << in.rdbuf();
  return parseLaunchConfig(text.str(), path, overrides);
}

}  // namespace ddsnav::launch
