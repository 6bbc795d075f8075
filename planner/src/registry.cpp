// Planner names -> factories. A planner whose source file is not in the tree yet is simply not listed
// (see planners.hpp), so the library always links.
#include "ddsnav/planner/planners.hpp"

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace ddsnav::planner {
namespace {

using Factory = std::unique_ptr<Planner> (*)();

const std::vector<std::pair<std::string, Factory>>& registry() {
  static const std::vector<std::pair<std::string, Factory>> planners = {
#ifdef DDSNAV_HAVE_RRT
      {"rrt", &makeRrtPlanner},
#endif
#ifdef DDSNAV_HAVE_RRTSTAR
      {"rrtstar", &makeRrtStarPlanner},
#endif
#ifdef DDSNAV_HAVE_LIRRT
      {"lirrt", &makeLiRrtPlanner},
#endif
#ifdef DDSNAV_HAVE_GART
      {"gart", &makeGartPlanner},
#endif
#ifdef DDSNAV_HAVE_APGDRRTSTAR
      {"apgd-rrtstar", &makeApgdRrtStarPlanner},
#endif
#ifdef DDSNAV_HAVE_RRRT
      {"rrrt", &makeRrrtPlanner},
#endif
#ifdef DDSNAV_HAVE_DDRRT
      {"ddrrt", &makeDdrrtPlanner},
#endif
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

}  // namespace ddsnav::planner
