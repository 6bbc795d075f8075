// ddsnav-bench reports: runs.csv (every run), summary.md (per scenario x planner), chart.svg.
#include "bench_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace ddsnav::bench {

namespace {

std::ofstream openOut(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path);
  return out;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// Percentile with linear interpolation between order statistics (NaN for no values).
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double rank = p * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(rank));
  const auto hi = static_cast<std::size_t>(std::ceil(rank));
  return v[lo] + (v[hi] - v[lo]) * (rank - static_cast<double>(lo));
}

std::string fmt(double x, const char* format) {
  if (!std::isfinite(x)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

// Scenarios and planners in the order they first appear (the command line's order).
template <class Key>
std::vector<std::string> inOrder(const std::vector<RunRecord>& runs, Key key) {
  std::vector<std::string> order;
  for (const RunRecord& r : runs) {
    if (std::find(order.begin(), order.end(), key(r)) == order.end()) order.push_back(key(r));
  }
  return order;
}

struct Cell {
  int runs = 0;
  int solved = 0;
  int valid = 0;
  bool kinodynamic = false;
  double median_first = NAN, p90_first = NAN, median_iter = NAN, median_vertices = NAN, median_cost = NAN,
         median_pous = NAN, median_checks = NAN, median_fgc = NAN;
  bool isOmpl(const std::string& planner) const { return planner.rfind("ompl:", 0) == 0; }
};

Cell summarise(const std::vector<RunRecord>& runs, const std::string& scenario, const std::string& planner) {
  Cell c;
  std::vector<double> first, iter, vertices, cost, pous, checks, fgc;
  for (const RunRecord& r : runs) {
    if (r.scenario != scenario || r.planner != planner) continue;
    ++c.runs;
    c.kinodynamic = c.kinodynamic || r.kinodynamic;
    checks.push_back(static_cast<double>(r.validity_checks));
    vertices.push_back(static_cast<double>(r.vertices));
    if (!r.solved) continue;
    ++c.solved;
    if (r.valid) ++c.valid;
    first.push_back(r.time_to_first_s);
    if (r.iterations_to_first >= 0) iter.push_back(static_cast<double>(r.iterations_to_first));
    else if (r.iterations >= 0) iter.push_back(static_cast<double>(r.iterations));
    cost.push_back(r.cost);
    if (r.pous >= 0.0) pous.push_back(r.pous);
    if (r.fgc >= 0) fgc.push_back(static_cast<double>(r.fgc));
  }
  c.median_first = percentile(first, 0.5);
  c.p90_first = percentile(first, 0.9);
  c.median_iter = percentile(iter, 0.5);
  c.median_vertices = percentile(vertices, 0.5);
  c.median_cost = percentile(cost, 0.5);
  c.median_pous = percentile(pous, 0.5);
  c.median_checks = percentile(checks, 0.5);
  c.median_fgc = percentile(fgc, 0.5);
  return c;
}

}  // namespace

void writeRunsCsv(const std::string& path, const std::vector<RunRecord>& runs) {
  std::ofstream out = openOut(path);
  out << "scenario,planner,seed,solved,exact,kinodynamic,valid,time_s,time_to_first_s,iterations,"
         "iterations_to_first,vertices,cost,pous,por,coverage,growth,validity_checks,fdc,fgc,note\n";
  char buf[512];
  for (const RunRecord& r : runs) {
    std::snprintf(buf, sizeof buf, "%d,%d,%d,%d,%.6f,%.6f,%lld,%lld,%lld,%.4f,%.4f,%.4f,%.4f,%.6g,%llu,%lld,%lld,",
                  r.solved, r.exact, r.kinodynamic, r.valid, r.time_s, r.time_to_first_s,
                  static_cast<long long>(r.iterations), static_cast<long long>(r.iterations_to_first),
                  static_cast<long long>(r.vertices), r.cost, r.pous, r.por, r.coverage, r.growth,
                  static_cast<unsigned long long>(r.validity_checks), static_cast<long long>(r.fdc),
                  static_cast<long long>(r.fgc));
    out << csvField(r.scenario) << ',' << csvField(r.planner) << ',' << r.seed << ',' << buf
        << csvField(r.invalid_reason) << '\n';
  }
}

void writeSummaryMarkdown(const std::string& path, const std::vector<RunRecord>& runs, const std::string& command,
                          double time_limit_s) {
  std::ofstream out = openOut(path);
  out << "# Planner benchmark\n\n`" << command << "`\n\n"
      << "Time limit " << time_limit_s << " s per run. Times, iterations, cost and POUS are over the solved runs; "
      << "\"valid\" counts solved runs whose path passed the independent check (collision free, and inside the "
      << "forward extending region edge by edge for kinodynamic planners). Iterations are to the first solution "
      << "(OMPL: the planner's own iteration counter where it has one). \"vs best OMPL\" divides the median time to "
      << "first solution by the fastest OMPL planner of the same kind (kinodynamic or geometric) in this run that "
      << "solved every seed.\n";
  const auto scenarios = inOrder(runs, [](const RunRecord& r) { return r.scenario; });
  const auto planners = inOrder(runs, [](const RunRecord& r) { return r.planner; });
  for (const std::string& scenario : scenarios) {
    std::map<std::string, Cell> cells;
    for (const std::string& planner : planners) cells[planner] = summarise(runs, scenario, planner);
    // Fastest OMPL planner of each kind that solved every run.
    std::map<bool, std::pair<std::string, double>> best_ompl;
    for (const std::string& planner : planners) {
      const Cell& c = cells[planner];
      if (!c.isOmpl(planner) || c.runs == 0 || c.solved != c.runs) continue;
      auto it = best_ompl.find(c.kinodynamic);
      if (it == best_ompl.end() || c.median_first < it->second.second) best_ompl[c.kinodynamic] = {planner, c.median_first};
    }
    out << "\n## " << scenario << "\n\n"
        << "| planner | kind | success | valid | median t first (ms) | p90 t first (ms) | median iterations | "
           "median vertices | median cost (m) | median POUS | median FGC | median validity checks | vs best OMPL |\n"
        << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& planner : planners) {
      const Cell& c = cells[planner];
      if (c.runs == 0) continue;
      std::string ratio = "-";
      if (!c.isOmpl(planner) && c.solved > 0) {
        const auto it = best_ompl.find(c.kinodynamic);
        if (it != best_ompl.end() && it->second.second > 0.0) {
          ratio = fmt(c.median_first / it->second.second, "x%.2f") + " (" + it->second.first + ")";
        }
      }
      out << "| " << planner << " | " << (c.kinodynamic ? "kinodynamic" : "geometric") << " | "
          << fmt(100.0 * c.solved / c.runs, "%.0f%%") << " | " << c.valid << "/" << c.solved << " | "
          << fmt(1e3 * c.median_first, "%.1f") << " | " << fmt(1e3 * c.p90_first, "%.1f") << " | "
          << fmt(c.median_iter, "%.0f") << " | " << fmt(c.median_vertices, "%.0f") << " | "
          << fmt(c.median_cost, "%.2f") << " | " << fmt(c.median_pous, "%.2f") << " | " << fmt(c.median_fgc, "%.0f")
          << " | " << fmt(c.median_checks, "%.0f") << " | " << ratio << " |\n";
    }
  }
}

void writeChartSvg(const std::string& path, const std::vector<RunRecord>& runs, double time_limit_s) {
  const auto scenarios = inOrder(runs, [](const RunRecord& r) { return r.scenario; });
  const auto planners = inOrder(runs, [](const RunRecord& r) { return r.planner; });
  // Log axis of median time to first solution, 0.1 ms .. time limit.
  const double lo = std::log10(0.1), hi = std::log10(std::max(1.0, time_limit_s * 1e3));
  const int bar = 14, gap = 26, left = 70, top = 40, plot_h = 300, legend_w = 190;
  const int group_w = static_cast<int>(planners.size()) * bar + gap;
  const int width = std::max(720, left + static_cast<int>(scenarios.size()) * group_w + legend_w);
  const int height = top + plot_h + 120;
  static const char* palette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
                                  "#7f7f7f", "#bcbd22", "#17becf", "#393b79", "#637939", "#8c6d31", "#843c39"};
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << left << "\" y=\"22\" font-size=\"13\">Median time to first solution (ms, log scale); "
      << "pale bar = not every seed solved; label = % solved</text>\n";
  auto y_of = [&](double ms) {
    const double t = (std::log10(std::max(ms, 0.1)) - lo) / (hi - lo);
    return top + plot_h - std::clamp(t, 0.0, 1.0) * plot_h;
  };
  for (double decade = 0.1; decade <= std::pow(10.0, hi) * 1.001; decade *= 10.0) {
    const double y = y_of(decade);
    svg << "<line x1=\"" << left << "\" x2=\"" << width - legend_w << "\" y1=\"" << y << "\" y2=\"" << y
        << "\" stroke=\"#ddd\"/><text x=\"" << left - 6 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">"
        << fmt(decade, decade < 1 ? "%.1f" : "%.0f") << "</text>\n";
  }
  for (std::size_t s = 0; s < scenarios.size(); ++s) {
    const int x0 = left + static_cast<int>(s) * group_w + gap / 2;
    for (std::size_t p = 0; p < planners.size(); ++p) {
      const Cell c = summarise(runs, scenarios[s], planners[p]);
      if (c.runs == 0) continue;
      const int x = x0 + static_cast<int>(p) * bar;
      const char* colour = palette[p % (sizeof palette / sizeof palette[0])];
      const double ms = std::isfinite(c.median_first) ? 1e3 * c.median_first : time_limit_s * 1e3;
      const double y = c.solved > 0 ? y_of(ms) : y_of(time_limit_s * 1e3);
      svg << "<rect x=\"" << x << "\" y=\"" << y << "\" width=\"" << bar - 2 << "\" height=\"" << top + plot_h - y
          << "\" fill=\"" << colour << "\" fill-opacity=\"" << (c.solved == c.runs ? "0.9" : "0.35") << "\"><title>"
          << planners[p] << " on " << scenarios[s] << ": " << fmt(ms, "%.1f") << " ms, " << c.solved << "/" << c.runs
          << " solved</title></rect>\n";
      svg << "<text x=\"" << x + bar / 2 - 1 << "\" y=\"" << y - 3 << "\" font-size=\"8\" text-anchor=\"middle\">"
          << fmt(100.0 * c.solved / c.runs, "%.0f") << "</text>\n";
    }
    svg << "<text transform=\"translate(" << x0 + group_w / 2 - gap / 2 << "," << top + plot_h + 12
        << ") rotate(30)\">" << scenarios[s] << "</text>\n";
  }
  for (std::size_t p = 0; p < planners.size(); ++p) {
    const int y = top + static_cast<int>(p) * 16;
    svg << "<rect x=\"" << width - legend_w + 15 << "\" y=\"" << y << "\" width=\"12\" height=\"12\" fill=\""
        << palette[p % (sizeof palette / sizeof palette[0])] << "\"/><text x=\"" << width - legend_w + 32 << "\" y=\""
        << y + 10 << "\">" << planners[p] << "</text>\n";
  }
  svg << "</svg>\n";
  std::ofstream out = openOut(path);
  out << svg.str();
}

}  // namespace ddsnav::bench
