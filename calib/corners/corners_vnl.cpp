#include "calib/corners/corners_vnl.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

namespace camlab::calib {

int BoardView::present_count() const {
  int n = 0;
  for (const auto& c : corners) n += c.present ? 1 : 0;
  return n;
}

namespace {

std::vector<std::string_view> split_ws(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

bool parse_double(std::string_view s, double* out) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(*out);
}

enum class WeightColumn { kNone, kLevel, kWeight };

}  // namespace

Result<std::vector<BoardView>> parse_corners_vnl(std::string_view text, const BoardSpec& board) {
  if (board.cols < 2 || board.rows < 2)
    return make_error("invalid_argument", "the board needs at least 2 x 2 inner corners");
  const size_t per_view = static_cast<size_t>(board.cols) * board.rows;
  WeightColumn weight_column = WeightColumn::kNone;
  bool have_header = false;
  std::vector<BoardView> views;
  std::set<std::string> seen;  // image names already read
  BoardView current;
  int line_no = 0;
  auto bad = [&](const std::string& why) {
    return make_error("bad_vnl", "corners.vnl line " + std::to_string(line_no) + ": " + why);
  };
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    auto fields = split_ws(line);
    if (fields.empty()) continue;
    if (fields[0][0] == '#') {
      // The legend: "# filename x y level" (the '#' may be glued to the first name).
      if (fields[0] == "#")
        fields.erase(fields.begin());
      else
        fields[0].remove_prefix(1);
      if (!have_header && fields.size() >= 3 && fields[0] == "filename") {
        have_header = true;
        if (fields.size() >= 4 && fields[3] == "level") weight_column = WeightColumn::kLevel;
        if (fields.size() >= 4 && fields[3] == "weight") weight_column = WeightColumn::kWeight;
      }
      continue;
    }
    if (!have_header) return bad("data before the '# filename x y ...' legend");
    const size_t expected = weight_column == WeightColumn::kNone ? 3 : 4;
    if (fields.size() != expected)
      return bad("expected " + std::to_string(expected) + " columns, got " +
                 std::to_string(fields.size()));
    const std::string name(fields[0]);
    if (current.corners.empty() || current.name != name) {
      if (!current.corners.empty()) {
        if (current.corners.size() == 1 && !current.corners[0].present) {
          // "img - - -": an image without a board.
        } else if (current.corners.size() != per_view) {
          return bad("image '" + current.name + "' has " + std::to_string(current.corners.size()) +
                     " corner rows; the board has " + std::to_string(per_view));
        } else {
          views.push_back(std::move(current));
        }
      }
      // An image's rows are consecutive: the same name again after another image would
      // make a second view of one image (and cannot be written back as two).
      if (!seen.insert(name).second)
        return bad("image '" + name + "' appears again after other images");
      current = BoardView{};
      current.name = name;
    } else if (current.corners.size() >= per_view) {
      return bad("image '" + name + "' has more than " + std::to_string(per_view) + " corner rows");
    }
    CornerObservation c;
    if (fields[1] == "-" || fields[2] == "-" ||
        (weight_column != WeightColumn::kNone && fields[3] == "-")) {
      c.present = false;
    } else {
      if (!parse_double(fields[1], &c.x_px) || !parse_double(fields[2], &c.y_px))
        return bad("x and y must be numbers or '-'");
      c.present = true;
      if (weight_column != WeightColumn::kNone) {
        double v = 0;
        if (!parse_double(fields[3], &v)) return bad("level/weight must be a number or '-'");
        if (!std::isfinite(v)) return bad("level/weight must be a finite number or '-'");
        // mrcal's convention: a negative level marks a corner to skip, as '-' does (and
        // 0.5^level would overflow to an infinite weight for a large negative one).
        c.weight = weight_column == WeightColumn::kLevel ? (v < 0 ? 0.0 : std::pow(0.5, v)) : v;
        if (!(c.weight > 0)) c.present = false;  // a non-positive weight marks an outlier
      }
    }
    current.corners.push_back(c);
  }
  if (!current.corners.empty()) {
    if (current.corners.size() == 1 && !current.corners[0].present) {
    } else if (current.corners.size() != per_view) {
      return make_error("bad_vnl", "image '" + current.name + "' has " +
                                       std::to_string(current.corners.size()) +
                                       " corner rows; the board has " + std::to_string(per_view));
    } else {
      views.push_back(std::move(current));
    }
  }
  return views;
}

Result<std::vector<BoardView>> read_corners_vnl(const std::filesystem::path& path,
                                                const BoardSpec& board) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error("not_found", "cannot read '" + path.string() + "'");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_corners_vnl(ss.str(), board);
}

std::string to_corners_vnl(const std::vector<BoardView>& views) {
  std::string out = "# filename x y level\n";
  char buf[128];
  for (const auto& v : views) {
    for (const auto& c : v.corners) {
      if (!c.present) {
        out += v.name + " - - -\n";
        continue;
      }
      const double level = c.weight > 0 ? -std::log2(c.weight) : 0.0;
      std::snprintf(buf, sizeof buf, " %.17g %.17g %.17g\n", c.x_px, c.y_px,
                    level == 0.0 ? 0.0 : level);
      out += v.name + buf;
    }
  }
  return out;
}

}  // namespace camlab::calib
