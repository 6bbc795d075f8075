#include "ddsnav/planner/svg.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace ddsnav::planner {
namespace {

// Maps one world plane (axes a, b of a 3-vector) into a pixel rectangle, b pointing up.
struct View {
  int a = 0, b = 1;
  double lo_a = 0, lo_b = 0, hi_a = 1, hi_b = 1;
  double x0 = 0, y0 = 0, scale = 1;  // pixel origin of the view's top-left corner
  double px(const Vec3& p) const { return x0 + (p[a] - lo_a) * scale; }
  double py(const Vec3& p) const { return y0 + (hi_b - p[b]) * scale; }
  double width() const { return (hi_a - lo_a) * scale; }
  double height() const { return (hi_b - lo_b) * scale; }
};

void shapeTop(std::ostringstream& out, const View& v, const Obstacle& o) {
  const double deg = o.yaw * 180.0 / M_PI;
  const Vec3& c = o.center;
  switch (o.type) {
    case ObstacleType::Box:
      out << "<rect x='" << v.px(c) - 0.5 * o.size.x() * v.scale << "' y='" << v.py(c) - 0.5 * o.size.y() * v.scale
          << "' width='" << o.size.x() * v.scale << "' height='" << o.size.y() * v.scale << "' transform='rotate("
          << -deg << ' ' << v.px(c) << ' ' << v.py(c) << ")' class='obs'/>\n";
      break;
    case ObstacleType::Sphere:
      out << "<circle cx='" << v.px(c) << "' cy='" << v.py(c) << "' r='" << o.radius * v.scale << "' class='obs'/>\n";
      break;
    case ObstacleType::Ellipsoid:
      out << "<ellipse cx='" << v.px(c) << "' cy='" << v.py(c) << "' rx='" << o.semi_axes.x() * v.scale << "' ry='"
          << o.semi_axes.y() * v.scale << "' transform='rotate(" << -deg << ' ' << v.px(c) << ' ' << v.py(c)
          << ")' class='obs'/>\n";
      break;
    case ObstacleType::Hill:
      // Contours at 20 %, 50 % and 80 % of the peak: d = sigma sqrt(2 ln(1/f)).
      for (double f : {0.2, 0.5, 0.8}) {
        out << "<circle cx='" << v.px(c) << "' cy='" << v.py(c) << "' r='" << o.sigma * std::sqrt(2.0 * std::log(1.0 / f)) * v.scale
            << "' class='hill'/>\n";
      }
      break;
  }
}

void shapeSide(std::ostringstream& out, const View& v, const Obstacle& o) {
  const Vec3& c = o.center;
  switch (o.type) {
    case ObstacleType::Box: {
      const double hx = 0.5 * (std::abs(std::cos(o.yaw)) * o.size.x() + std::abs(std::sin(o.yaw)) * o.size.y());
      out << "<rect x='" << v.px(c - Vec3(hx, 0, 0)) << "' y='" << v.py(c + Vec3(0, 0, 0.5 * o.size.z())) << "' width='"
          << 2 * hx * v.scale << "' height='" << o.size.z() * v.scale << "' class='obs'/>\n";
      break;
    }
    case ObstacleType::Sphere:
      out << "<circle cx='" << v.px(c) << "' cy='" << v.py(c) << "' r='" << o.radius * v.scale << "' class='obs'/>\n";
      break;
    case ObstacleType::Ellipsoid: {
      const double hx = std::hypot(std::cos(o.yaw) * o.semi_axes.x(), std::sin(o.yaw) * o.semi_axes.y());
      out << "<ellipse cx='" << v.px(c) << "' cy='" << v.py(c) << "' rx='" << hx * v.scale << "' ry='"
          << o.semi_axes.z() * v.scale << "' class='obs'/>\n";
      break;
    }
    case ObstacleType::Hill: {
      out << "<polygon class='obs' points='";
      const double span = 4.0 * o.sigma;
      for (int i = 0; i <= 64; ++i) {
        const double x = c.x() - span + 2.0 * span * i / 64.0;
        const double z = o.height * std::exp(-(x - c.x()) * (x - c.x()) / (2.0 * o.sigma * o.sigma));
        out << v.px(Vec3(x, 0, z)) << ',' << v.py(Vec3(x, 0, z)) << ' ';
      }
      out << v.px(Vec3(c.x() + span, 0, 0)) << ',' << v.py(Vec3(0, 0, 0)) << ' ' << v.px(Vec3(c.x() - span, 0, 0)) << ','
          << v.py(Vec3(0, 0, 0)) << "'/>\n";
      break;
    }
  }
}

void drawView(std::ostringstream& out, const View& v, const SvgScene& scene, bool top) {
  const Scenario& s = *scene.scenario;
  out << "<svg x='" << v.x0 << "' y='" << v.y0 << "' width='" << v.width() << "' height='" << v.height()
      << "' overflow='hidden'><g transform='translate(" << -v.x0 << ',' << -v.y0 << ")'>\n";
  out << "<rect x='" << v.x0 << "' y='" << v.y0 << "' width='" << v.width() << "' height='" << v.height() << "' class='bounds'/>\n";
  for (const Obstacle& o : s.obstacles) top ? shapeTop(out, v, o) : shapeSide(out, v, o);
  if (!scene.tree.empty()) {
    out << "<path class='tree' d='";
    for (const TreeEdge& e : scene.tree) out << 'M' << v.px(e.from) << ',' << v.py(e.from) << 'L' << v.px(e.to) << ',' << v.py(e.to);
    out << "'/>\n";
  }
  if (!scene.path.empty()) {
    out << "<polyline class='path' points='";
    for (const State& st : scene.path) out << v.px(st.position) << ',' << v.py(st.position) << ' ';
    out << "'/>\n";
  }
  for (const EllipsoidObstacle& e : scene.ellipses) {
    // The ellipse's outline in this view: the rim of its projection, traced as a polygon.
    out << "<polygon class='perceived' points='";
    for (int i = 0; i < 72; ++i) {
      const double t = 2.0 * M_PI * i / 72.0;
      const Vec3 local = top ? Vec3(e.semi_axes.x() * std::cos(t), e.semi_axes.y() * std::sin(t), 0.0)
                             : Vec3(e.semi_axes.x() * std::cos(t), 0.0, e.semi_axes.z() * std::sin(t));
      const Vec3 p = e.center + e.axes * local;
      out << v.px(p) << ',' << v.py(p) << ' ';
    }
    out << "'/>\n";
  }
  for (const SvgPolyline& line : scene.polylines) {
    if (line.points.empty()) continue;
    out << "<polyline fill='none' stroke-linejoin='round' stroke='" << line.colour << "' stroke-width='" << line.width_px << "'"
        << (line.dashed ? " stroke-dasharray='6,4'" : "") << " points='";
    for (const Vec3& p : line.points) out << v.px(p) << ',' << v.py(p) << ' ';
    out << "'/>\n";
  }
  const double goal_r = std::max(2.0, s.goal_radius * v.scale);
  out << "<circle cx='" << v.px(s.goal) << "' cy='" << v.py(s.goal) << "' r='" << goal_r << "' class='goal'/>\n";
  out << "<circle cx='" << v.px(s.start) << "' cy='" << v.py(s.start) << "' r='4' class='start'/>\n";
  out << "</g></svg>\n";
}

std::string escapeXml(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace

std::string renderSvg(const SvgScene& scene, int width_px) {
  if (scene.scenario == nullptr) throw std::invalid_argument("renderSvg: no scenario");
  const Scenario& s = *scene.scenario;
  const double margin = 10.0, title_h = scene.title.empty() ? 0.0 : 24.0;
  const bool three_d = s.dimensions == 3;
  const Vec3 extent = s.bounds_max - s.bounds_min;
  View top;
  top.lo_a = s.bounds_min.x(), top.hi_a = s.bounds_max.x(), top.lo_b = s.bounds_min.y(), top.hi_b = s.bounds_max.y();
  View side;
  side.b = 2;
  side.lo_a = s.bounds_min.x(), side.hi_a = s.bounds_max.x(), side.lo_b = s.bounds_min.z(), side.hi_b = s.bounds_max.z();
  // 3-D: both views share the x scale, placed side by side.
  const double usable = width_px - (three_d ? 3.0 : 2.0) * margin;
  const double scale = three_d ? usable / (2.0 * extent.x()) : usable / extent.x();
  top.scale = side.scale = scale;
  top.x0 = margin, top.y0 = margin + title_h;
  side.x0 = 2.0 * margin + top.width(), side.y0 = margin + title_h;
  const double height = margin * 2 + title_h + std::max(top.height(), three_d ? side.height() : 0.0);

  std::ostringstream out;
  out << "<svg xmlns='http://www.w3.org/2000/svg' width='" << width_px << "' height='" << height << "' viewBox='0 0 "
      << width_px << ' ' << height << "'>\n"
      << "<style>.bounds{fill:#fff;stroke:#000;stroke-width:1}.obs{fill:#8a8f99;stroke:#444;stroke-width:0.5}"
         ".hill{fill:none;stroke:#8a6d3b;stroke-width:1}.tree{fill:none;stroke:#7fb2e5;stroke-width:0.5}"
         ".path{fill:none;stroke:#d62728;stroke-width:2.5;stroke-linejoin:round}.goal{fill:#2ca02c;fill-opacity:0.5;stroke:#2ca02c}"
         ".start{fill:#1f77b4}.perceived{fill:#ff7f0e;fill-opacity:0.15;stroke:#ff7f0e;stroke-width:1.2}text{font-family:sans-serif;font-size:14px}</style>\n";
  if (!scene.title.empty()) out << "<text x='" << margin << "' y='18'>" << escapeXml(scene.title) << "</text>\n";
  // Legend for the labelled overlays, right-aligned in the title row.
  double legend_x = width_px - margin;
  for (auto it = scene.polylines.rbegin(); it != scene.polylines.rend(); ++it) {
    if (it->label.empty()) continue;
    legend_x -= 8.0 * it->label.size() + 34.0;
    out << "<line x1='" << legend_x << "' y1='13' x2='" << legend_x + 22 << "' y2='13' stroke='" << it->colour
        << "' stroke-width='3'" << (it->dashed ? " stroke-dasharray='6,4'" : "") << "/><text x='" << legend_x + 26
        << "' y='18'>" << escapeXml(it->label) << "</text>\n";
  }
  drawView(out, top, scene, true);
  if (three_d) drawView(out, side, scene, false);
  out << "</svg>\n";
  return out.str();
}

void writeSvg(const std::string& path, const SvgScene& scene, int width_px) {
  std::ofstream file(path);
  if (!file) throw std::runtime_error("cannot write SVG file '" + path + "'");
  file << renderSvg(scene, width_px);
  if (!file) throw std::runtime_error("failed writing SVG file '" + path + "'");
}

}  // namespace ddsnav::planner
