#include <ddsnav/foxglove/svg.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace ddsnav::foxglove {
namespace {

using nlohmann::json;

double yawOf(const json& q) {
  const double x = q["x"], y = q["y"], z = q["z"], w = q["w"];
  return std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}

std::string colour(const json& c, const char* what) {
  std::ostringstream s;
  s << what << "=\"rgb(" << std::lround(255 * c["r"].get<double>()) << ',' << std::lround(255 * c["g"].get<double>()) << ','
    << std::lround(255 * c["b"].get<double>()) << ")\" " << what << "-opacity=\"" << c["a"].get<double>() << "\"";
  return s.str();
}

std::string escape(const std::string& text) {
  std::string out;
  for (char ch : text) {
    if (ch == '<') out += "&lt;";
    else if (ch == '>') out += "&gt;";
    else if (ch == '&') out += "&amp;";
    else out += ch;
  }
  return out;
}

// Channels drawn first end up underneath.
int layer(const std::string& channel) {
  if (channel.find("scenario") != std::string::npos) return 0;
  if (channel.find("octomap") != std::string::npos) return 1;  // the map over the truth it found
  if (channel.find("obstacles") != std::string::npos) return 2;
  if (channel.find("trajectory") != std::string::npos) return 4;
  if (channel.find("path") != std::string::npos) return 3;
  return 5;
}

struct Frame {
  double min_x, min_y, scale, height_px, top_px;
  double px(double x) const { return (x - min_x) * scale; }
  double py(double y) const { return top_px + height_px - (y - min_y) * scale; }
};

}  // namespace

void SceneSvg::add(const std::string& channel, const json& update) {
  auto& entities = entities_[channel];
  for (const auto& d : update.value("deletions", json::array())) {
    if (d.value("type", 0) == 1) entities.clear();
    else entities.erase(d.value("id", ""));
  }
  for (const auto& e : update.value("entities", json::array())) entities[e.value("id", "")] = e;
}

std::size_t SceneSvg::entityCount() const {
  std::size_t n = 0;
  for (const auto& [c, e] : entities_) n += e.size();
  return n;
}

std::string SceneSvg::render(const std::string& title, double width_px) const {
  // Extent of everything drawn (positions and half-sizes).
  double lo_x = std::numeric_limits<double>::infinity(), lo_y = lo_x, hi_x = -lo_x, hi_y = -lo_x;
  auto grow = [&](double x, double y, double r) {
    lo_x = std::min(lo_x, x - r), hi_x = std::max(hi_x, x + r), lo_y = std::min(lo_y, y - r), hi_y = std::max(hi_y, y + r);
  };
  // Labels only where they stay readable: channels of a few entities (not a hundred obstacle labels).
  constexpr std::size_t kMaxLabelled = 10;
  struct Item {
    int layer;
    const json* entity;
    bool labels;
  };
  std::vector<Item> order;
  for (const auto& [channel, entities] : entities_)
    for (const auto& [id, e] : entities) {
      order.push_back({layer(channel), &e, entities.size() <= kMaxLabelled});
      for (const char* kind : {"cubes", "spheres", "cylinders"})
        for (const auto& p : e[kind])
          grow(p["pose"]["position"]["x"], p["pose"]["position"]["y"], std::max(p["size"]["x"].get<double>(), p["size"]["y"].get<double>()) / 2);
      for (const auto& l : e["lines"])
        for (const auto& p : l["points"]) grow(p["x"], p["y"], 0);
      for (const auto& a : e["arrows"]) grow(a["pose"]["position"]["x"], a["pose"]["position"]["y"], 1);
    }
  std::stable_sort(order.begin(), order.end(), [](const Item& a, const Item& b) { return a.layer < b.layer; });
  if (!std::isfinite(lo_x)) lo_x = lo_y = 0, hi_x = hi_y = 1;
  const double margin = 0.03 * std::max(hi_x - lo_x, hi_y - lo_y) + 0.5;
  lo_x -= margin, lo_y -= margin, hi_x += margin, hi_y += margin;
  const double scale = width_px / (hi_x - lo_x);
  const Frame f{lo_x, lo_y, scale, (hi_y - lo_y) * scale, 28};

  std::ostringstream s;
  s.precision(5);
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width_px << "\" height=\"" << f.top_px + f.height_px
    << "\" font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"#15161a\"/>\n"
    << "<text x=\"8\" y=\"19\" font-size=\"14\" fill=\"#e0e0e0\">" << escape(title) << "</text>\n";
  for (const auto& [layer_index, e, labels] : order) {
    const json& entity = *e;
    for (const char* kind : {"cubes", "spheres", "cylinders"}) {
      const bool box = std::string(kind) == "cubes";
      for (const auto& p : entity[kind]) {
        const double x = f.px(p["pose"]["position"]["x"]), y = f.py(p["pose"]["position"]["y"]);
        const double w = p["size"]["x"].get<double>() * scale, h = p["size"]["y"].get<double>() * scale;
        const double deg = -yawOf(p["pose"]["orientation"]) * 180 / M_PI;
        s << "<g transform=\"translate(" << x << ',' << y << ") rotate(" << deg << ")\">";
        if (box) s << "<rect x=\"" << -w / 2 << "\" y=\"" << -h / 2 << "\" width=\"" << w << "\" height=\"" << h << "\" ";
        else s << "<ellipse rx=\"" << w / 2 << "\" ry=\"" << h / 2 << "\" ";
        s << colour(p["color"], "fill") << "/></g>\n";
      }
    }
    for (const auto& l : entity["lines"]) {
      s << (l["type"] == 1 ? "<polygon" : "<polyline") << " fill=\"none\" stroke-width=\""
        << std::max(1.0, l["thickness"].get<double>() * scale) << "\" " << colour(l["color"], "stroke") << " points=\"";
      for (const auto& p : l["points"]) s << f.px(p["x"]) << ',' << f.py(p["y"]) << ' ';
      s << "\"/>\n";
    }
    for (const auto& a : entity["arrows"]) {
      const double x = f.px(a["pose"]["position"]["x"]), y = f.py(a["pose"]["position"]["y"]);
      const double yaw = yawOf(a["pose"]["orientation"]);
      const double len = std::max(12.0, (a["shaft_length"].get<double>() + a["head_length"].get<double>()) * scale);
      s << "<line x1=\"" << x << "\" y1=\"" << y << "\" x2=\"" << x + len * std::cos(yaw) << "\" y2=\"" << y - len * std::sin(yaw)
        << "\" stroke-width=\"3\" " << colour(a["color"], "stroke") << "/><circle cx=\"" << x << "\" cy=\"" << y << "\" r=\"5\" "
        << colour(a["color"], "fill") << "/>\n";
    }
    if (labels)
      for (const auto& t : entity["texts"])
        s << "<text x=\"" << f.px(t["pose"]["position"]["x"]) + 4 << "\" y=\"" << f.py(t["pose"]["position"]["y"]) - 4
        << "\" font-size=\"11\" fill=\"#f0f0f0\">" << escape(t["text"]) << "</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

}  // namespace ddsnav::foxglove
