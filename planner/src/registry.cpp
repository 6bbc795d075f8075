// Planner names -> factories. Every planner is listed here: a missing factory is a link error, never a
// planner (and its tests) quietly gone.
#include "ddsnav/planner/planners.hpp"

#include <cerrno>
#include <cstdio>
#include <optional>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ddsnav::planner {
namespace {

using Factory = std::unique_ptr<Planner> (*)();

const std::vector<std::pair<std::string, Factory>>& registry() {
  static const std::vector<std::pair<std::string, Factory>> planners = {
      {"rrt", &makeRrtPlanner},
      {"rrt-controls", &makeRrtControlsPlanner},
      {"rrtstar", &makeRrtStarPlanner},
      {"lirrt", &makeLiRrtPlanner},
      {"gart", &makeGartPlanner},
      {"gart-lazy", &makeGartLazyPlanner},
      {"apgd-rrtstar", &makeApgdRrtStarPlanner},
      {"rrrt", &makeRrrtPlanner},
      {"ddrrt", &makeDdrrtPlanner},
  };
  return planners;
}

}  // namespace

std::vector<std::string> plannerNames() {
  std::vector<std::string> names;
  for (const auto& [name, factory] : registry()) names.push_back(name);
  return names;
}

std::unique_ptr<Planner> makePlanner(const std::string& name) {
  for (const auto& [known, factory] : registry()) {
    if (known == name) return factory();
  }
  std::string list;
  for (const auto& known : plannerNames()) list += (list.empty() ? "" : ", ") + known;
  throw std::invalid_argument("unknown planner '" + name + "' (known: " + list + ")");
}

namespace {

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", x);
  return text;
}

std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

// The whole text as a finite number, else nullopt.
std::optional<double> parseReal(const std::string& text) {
  if (text.empty()) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace

std::string PlannerOption::range() const {
  switch (type) {
    case Type::kInteger: return "an integer in [" + number(min) + ", " + number(max) + "]";
    case Type::kReal: return "a number in [" + number(min) + ", " + number(max) + "]";
    case Type::kBoolean: return "true or false";
  }
  return {};
}

void Planner::addOption(const std::string& name, int* target, int min, int max, const std::string& description) {
  Binding b;
  b.option = {name, description, PlannerOption::Type::kInteger, double(min), double(max), {}};
  b.integer = target;
  bindings_.push_back(b);
}

void Planner::addOption(const std::string& name, double* target, double min, double max, const std::string& description) {
  Binding b;
  b.option = {name, description, PlannerOption::Type::kReal, min, max, {}};
  b.real = target;
  bindings_.push_back(b);
}

void Planner::addOption(const std::string& name, bool* target, const std::string& description) {
  Binding b;
  b.option = {name, description, PlannerOption::Type::kBoolean, 0.0, 1.0, {}};
  b.boolean = target;
  bindings_.push_back(b);
}

std::vector<PlannerOption> Planner::options() const {
  std::vector<PlannerOption> out;
  for (const Binding& b : bindings_) {
    PlannerOption o = b.option;
    if (b.integer) o.value = std::to_string(*b.integer);
    if (b.real) o.value = number(*b.real);
    if (b.boolean) o.value = *b.boolean ? "true" : "false";
    out.push_back(std::move(o));
  }
  return out;
}

void Planner::setOption(const std::string& option_name, const std::string& raw_value) {
  const std::string value = trimmed(raw_value);
  for (Binding& b : bindings_) {
    if (b.option.name != option_name) continue;
    const std::string what = "planner " + name() + ", option " + option_name + ": expected " + b.option.range() +
                             ", got '" + value + "'";
    if (b.boolean) {
      if (value == "true" || value == "on" || value == "yes" || value == "1") *b.boolean = true;
      else if (value == "false" || value == "off" || value == "no" || value == "0") *b.boolean = false;
      else throw std::invalid_argument(what);
      return;
    }
    const std::optional<double> v = parseReal(value);
    if (!v || *v < b.option.min || *v > b.option.max) throw std::invalid_argument(what);
    if (b.integer) {
      if (*v != std::floor(*v)) throw std::invalid_argument(what);
      *b.integer = static_cast<int>(*v);
    } else {
      *b.real = *v;
    }
    return;
  }
  std::string known;
  for (const Binding& b : bindings_) known += (known.empty() ? "" : ", ") + b.option.name;
  throw std::invalid_argument("planner " + name() + " has no option '" + option_name + "' (" +
                              (known.empty() ? std::string("it has no options") : "its options: " + known) + ")");
}

void Planner::checkOptions() const {
  for (const Binding& b : bindings_) {
    const double v = b.integer ? double(*b.integer) : b.real ? *b.real : 0.0;
    if (b.boolean || (v >= b.option.min && v <= b.option.max)) continue;
    throw std::invalid_argument("planner " + name() + ", option " + b.option.name + ": expected " + b.option.range() +
                                ", got " + number(v));
  }
}

void applyOptions(Planner& planner, const std::vector<std::string>& assignments) {
  for (const std::string& a : assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos || trimmed(a.substr(0, eq)).empty()) {
      throw std::invalid_argument("planner " + planner.name() + ": option '" + a + "' is not of the form name=value");
    }
    planner.setOption(trimmed(a.substr(0, eq)), a.substr(eq + 1));
  }
}

std::map<std::string, std::vector<std::string>> parsePlannerOptions(const std::vector<std::string>& entries) {
  std::map<std::string, std::vector<std::string>> out;
  for (const std::string& e : entries) {
    const auto eq = e.find('=');
    const auto dot = e.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot == 0 || dot > eq) {
      throw std::invalid_argument("option entry '" + e + "' is not of the form planner.option=value");
    }
    out[trimmed(e.substr(0, dot))].push_back(e.substr(dot + 1));
  }
  return out;
}

std::unique_ptr<Planner> makePlannerFromSpec(const std::string& spec) {
  const auto open = spec.find('{');
  if (open == std::string::npos) return makePlanner(trimmed(spec));
  if (spec.back() != '}') throw std::invalid_argument("planner spec '" + spec + "': expected name{option=value,...}");
  auto planner = makePlanner(trimmed(spec.substr(0, open)));
  std::vector<std::string> assignments;
  const std::string body = spec.substr(open + 1, spec.size() - open - 2);
  std::size_t from = 0;
  while (from <= body.size()) {
    const auto comma = body.find(',', from);
    const std::string part = trimmed(body.substr(from, comma == std::string::npos ? std::string::npos : comma - from));
    if (!part.empty()) assignments.push_back(part);
    if (comma == std::string::npos) break;
    from = comma + 1;
  }
  applyOptions(*planner, assignments);
  return planner;
}

}  // namespace ddsnav::planner
