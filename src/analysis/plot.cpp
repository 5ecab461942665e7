// write_plot(): a gnuplot script with the data inline, run by gnuplot (pngcairo). The
// script is kept beside the PNG (NAME.gp): rerun it with `gnuplot NAME.gp` to restyle a
// plot, or change its terminal to get SVG or PDF.
#include "analysis/plot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <string>

#include "base/atomic_file.h"
#include "base/format.h"

extern char** environ;

namespace camlab::analysis {
namespace {

// What gnuplot needs to read a string literal in double quotes.
std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out + "\"";
}

std::string colour_of(int bgr) {
  return format_printf("\"#%02x%02x%02x\"", bgr & 255, (bgr >> 8) & 255, (bgr >> 16) & 255);
}

bool near_white(int bgr) {
  return (bgr & 255) > 0xe0 && ((bgr >> 8) & 255) > 0xe0 && ((bgr >> 16) & 255) > 0xe0;
}

std::string number(double v) { return format_printf("%.10g", v); }

// The drawable points of a series as a datablock: x y [dy | dx dy] per line.
std::string series_block(const PlotSpec& spec, const PlotSeries& s, const std::string& name,
                         int* points) {
  auto drawable = [&](double x, double y) {
    return std::isfinite(x) && std::isfinite(y) && (!spec.log_x || x > 0) && (!spec.log_y || y > 0);
  };
  const bool vectors = !s.dx.empty() && !s.dy.empty();
  std::string block = name + " << EOD\n";
  for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    if (!drawable(s.x[i], s.y[i])) continue;
    // A vector is drawn whole or not at all (its end, too, must be drawable).
    if (vectors &&
        (i >= s.dx.size() || i >= s.dy.size() || !drawable(s.x[i] + s.dx[i], s.y[i] + s.dy[i])))
      continue;
    block += number(s.x[i]) + " " + number(s.y[i]);
    if (vectors) {
      block += " " + number(s.dx[i]) + " " + number(s.dy[i]);
    } else if (!s.y_error.empty()) {
      block += " " + number(i < s.y_error.size() && std::isfinite(s.y_error[i]) ? s.y_error[i] : 0);
    }
    block += "\n";
    ++*points;
  }
  return block + "EOD\n";
}

// The heat map's cells as "x y value" rows (blank line between rows), NaN left blank.
std::string heatmap_block(const PlotHeatmap& h) {
  std::string block = "$heat << EOD\n";
  for (int j = 0; j < h.rows; ++j) {
    for (int i = 0; i < h.cols; ++i) {
      const double x = h.x0 + (i + 0.5) * (h.x1 - h.x0) / h.cols;
      const double y = h.y0 + (j + 0.5) * (h.y1 - h.y0) / h.rows;
      const double v = h.values[static_cast<size_t>(j) * h.cols + i];
      const bool shown = std::isfinite(v) && (!h.log_scale || v > 0);
      block += number(x) + " " + number(y) + " " + (shown ? number(v) : std::string("NaN")) + "\n";
    }
    block += "\n";
  }
  return block + "EOD\n";
}

// Ticks at 1, 2 and 5 times powers of ten over a log colour bar's values: a range within
// one decade would otherwise get a single labelled tick.
std::string log_ticks(const PlotHeatmap& h) {
  double lo = h.range ? h.range->first : INFINITY, hi = h.range ? h.range->second : -INFINITY;
  if (!h.range)
    for (double v : h.values)
      if (std::isfinite(v) && v > 0) lo = std::min(lo, v), hi = std::max(hi, v);
  if (!(lo > 0) || !(hi >= lo)) return "";
  std::string ticks;
  for (int decade = static_cast<int>(std::floor(std::log10(lo)));
       decade <= static_cast<int>(std::ceil(std::log10(hi))); ++decade)
    for (double m : {1.0, 2.0, 5.0}) {
      const double v = m * std::pow(10.0, decade);
      if (v >= lo && v <= hi) ticks += (ticks.empty() ? "" : ", ") + format_printf("%g", v);
    }
  return ticks.empty() ? "" : "set cbtics (" + ticks + ")\n";
}

// "plot" terms for one series: markers, a line, error bars, vectors or bars. A near-white
// marker (drawn over a heat map) gets a black ring, which also stands for it in the key.
std::string series_terms(const PlotSeries& s, const std::string& name) {
  const std::string title = s.label.empty() ? "notitle" : "title " + quoted(s.label);
  const std::string colour = "lc rgb " + colour_of(s.color_bgr);
  const double size = std::max(0.3, s.marker_px / 4.0);
  if (!s.dx.empty() && !s.dy.empty())
    return name + " using 1:2:3:4 with vectors head size screen 0.006,25 " + colour + " " + title;
  if (s.bar_width > 0) return name + " using 1:2 with boxes " + colour + " " + title;
  if (s.line) return name + " using 1:2 with lines lw 2 " + colour + " " + title;
  if (!s.y_error.empty())
    return name + format_printf(" using 1:2:3 with yerrorbars pt 7 ps %.2f ", size) + colour + " " +
           title;
  if (near_white(s.color_bgr))
    return name + format_printf(" using 1:2 with points pt 7 ps %.2f ", size) + colour +
           " notitle, " + name + format_printf(" using 1:2 with points pt 6 ps %.2f ", size) +
           "lc rgb \"#000000\" " + title;
  return name + format_printf(" using 1:2 with points pt 7 ps %.2f ", size) + colour + " " + title;
}

// Runs `gnuplot script`; its complaints become the error's message.
Status run_gnuplot(const std::filesystem::path& script) {
  int pipe_fds[2];
  if (pipe2(pipe_fds, O_CLOEXEC) != 0)
    return make_error("plotter_failed", std::string("cannot make a pipe: ") + std::strerror(errno));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], 1);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], 2);
  const std::string path = script.string();
  char* argv[] = {const_cast<char*>("gnuplot"), const_cast<char*>(path.c_str()), nullptr};
  pid_t child = 0;
  const int spawned = posix_spawnp(&child, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  if (spawned != 0) {
    close(pipe_fds[0]);
    return make_error("plotter_failed", std::string("cannot run gnuplot (") +
                                            std::strerror(spawned) +
                                            "): install it (scripts/install-deps.sh does)");
  }
  std::string said;
  char buffer[4096];
  for (;;) {
    const ssize_t n = read(pipe_fds[0], buffer, sizeof buffer);
    if (n > 0 && said.size() < 4000) said.append(buffer, static_cast<size_t>(n));
    if (n == 0 || (n < 0 && errno != EINTR)) break;
  }
  close(pipe_fds[0]);
  int status = 0;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return make_error("plotter_failed", "gnuplot refused " + path + ": " + said.substr(0, 600));
  return {};
}

}  // namespace

std::string gnuplot_script(const std::filesystem::path& png_path, const PlotSpec& spec,
                           int* points) {
  const PlotHeatmap* heat =
      spec.heatmap && spec.heatmap->cols >= 1 && spec.heatmap->rows >= 1 &&
              spec.heatmap->values.size() ==
                  static_cast<size_t>(spec.heatmap->cols) * spec.heatmap->rows &&
              spec.heatmap->x1 != spec.heatmap->x0 && spec.heatmap->y1 != spec.heatmap->y0
          ? &*spec.heatmap
          : nullptr;
  std::string data, terms;
  *points = 0;
  for (size_t k = 0; k < spec.series.size(); ++k) {
    const std::string name = "$s" + std::to_string(k);
    const int before = *points;
    data += series_block(spec, spec.series[k], name, points);
    if (*points == before) continue;
    terms += (terms.empty() ? "" : ", ") + series_terms(spec.series[k], name);
  }
  std::string s = format_printf("set terminal pngcairo size %d,%d font \"sans,10\" noenhanced\n",
                                std::max(200, spec.width_px), std::max(150, spec.height_px)) +
                  "set output " + quoted(png_path.string()) + "\n" + "set title " +
                  quoted(spec.title) + "\n" + "set xlabel " + quoted(spec.x_label) + "\n" +
                  "set ylabel " + quoted(spec.y_label) + "\n" +
                  // Legends beside the data, never over it; a light grid to read values off.
                  "set key below horizontal Left reverse samplen 2 maxrows 4 height 1.5\n" +
                  "set grid lc rgb \"#d8d8d8\"\n";
  // Points on the frame's edge are hard to read: autoscaled axes get a margin.
  // Autoscaled axes span the data exactly ("fix": not out to the next tick, which can
  // double an axis) plus a small margin.
  const std::string x_margin = !heat && !spec.x_range ? "graph 0.03" : "0";
  const std::string y_margin = !heat && !spec.y_range ? "graph 0.06" : "0";
  s += "set offsets " + x_margin + ", " + x_margin + ", " + y_margin + ", " + y_margin + "\n";
  if (!heat && !spec.x_range) s += "set autoscale xfix\n";
  if (!heat && !spec.y_range) s += "set autoscale yfix\n";
  if (spec.log_x) s += "set logscale x 10\n";
  if (spec.log_y) s += "set logscale y 10\n";
  if (spec.equal_aspect) s += "set size ratio -1\n";
  if (spec.x_range)
    s += "set xrange [" + number(spec.x_range->first) + ":" + number(spec.x_range->second) + "]\n";
  // Image coordinates grow downwards: the range given, or the data's, high to low.
  if (spec.y_range)
    s += spec.y_down ? "set yrange [" + number(spec.y_range->second) + ":" +
                           number(spec.y_range->first) + "]\n"
                     : "set yrange [" + number(spec.y_range->first) + ":" +
                           number(spec.y_range->second) + "]\n";
  else if (spec.y_down)
    s += "set yrange [*:*] reverse\n";
  for (const PlotSeries& series : spec.series)
    if (series.bar_width > 0)
      s += "set boxwidth " + number(series.bar_width) +
           " absolute\nset style fill solid 0.6 noborder\n";
  if (heat) {
    data += heatmap_block(*heat);
    // viridis, as matplotlib and mrcal's plots use: perceptually even, readable in grey.
    s += "set palette defined (0 '#440154', 0.25 '#3b528b', 0.5 '#21918c', 0.75 '#5ec962', "
         "1 '#fde725')\n";
    s += "set cblabel " + quoted(heat->label) + "\n";
    if (heat->log_scale) s += "set logscale cb 10\n" + log_ticks(*heat);
    if (heat->range)
      s += "set cbrange [" + number(heat->range->first) + ":" + number(heat->range->second) + "]\n";
    if (!spec.x_range)
      s += "set xrange [" + number(std::min(heat->x0, heat->x1)) + ":" +
           number(std::max(heat->x0, heat->x1)) + "]\n";
    if (!spec.y_range)
      s += spec.y_down ? "set yrange [" + number(std::max(heat->y0, heat->y1)) + ":" +
                             number(std::min(heat->y0, heat->y1)) + "]\n"
                       : "set yrange [" + number(std::min(heat->y0, heat->y1)) + ":" +
                             number(std::max(heat->y0, heat->y1)) + "]\n";
    terms = "$heat using 1:2:3 with image notitle" + (terms.empty() ? "" : ", " + terms);
  }
  return s + data + "plot " + terms + "\n";
}

nlohmann::json to_json(const PlotSpec& spec) {
  using nlohmann::json;
  auto values = [](const std::vector<double>& v) {
    json out = json::array();
    for (double x : v) out.push_back(std::isfinite(x) ? json(x) : json(nullptr));
    return out;
  };
  auto range = [](const std::optional<std::pair<double, double>>& r) {
    return r ? json::array({r->first, r->second}) : json(nullptr);
  };
  json series = json::array();
  for (const PlotSeries& s : spec.series) {
    json j = {{"label", s.label},
              {"line", s.line},
              {"colour", format_printf("#%02x%02x%02x", s.color_bgr & 255, (s.color_bgr >> 8) & 255,
                                       (s.color_bgr >> 16) & 255)},
              {"x", values(s.x)},
              {"y", values(s.y)}};
    if (!s.y_error.empty()) j["y_error"] = values(s.y_error);
    if (!s.dx.empty()) j["dx"] = values(s.dx), j["dy"] = values(s.dy);
    if (s.bar_width > 0) j["bar_width"] = s.bar_width;
    series.push_back(std::move(j));
  }
  json out = {{"title", spec.title},
              {"x_label", spec.x_label},
              {"y_label", spec.y_label},
              {"log_x", spec.log_x},
              {"log_y", spec.log_y},
              {"y_down", spec.y_down},
              {"x_range", range(spec.x_range)},
              {"y_range", range(spec.y_range)},
              {"series", std::move(series)}};
  if (spec.heatmap) {
    const PlotHeatmap& h = *spec.heatmap;
    out["heatmap"] = {{"cols", h.cols},
                      {"rows", h.rows},
                      {"x0", h.x0},
                      {"x1", h.x1},
                      {"y0", h.y0},
                      {"y1", h.y1},
                      {"label", h.label},
                      {"log_scale", h.log_scale},
                      {"range", range(h.range)},
                      {"values", values(h.values)}};
  }
  return out;
}

Status write_plot(const std::filesystem::path& png_path, const PlotSpec& spec) {
  int points = 0;
  const std::string script = gnuplot_script(png_path, spec, &points);
  if (points == 0 && !(spec.heatmap && !spec.heatmap->values.empty()))
    return make_error("empty_plot", "nothing to plot in " + spec.title);
  std::filesystem::path script_path = png_path;
  script_path.replace_extension(".gp");
  if (Status written = write_file_atomically(script_path, script); !written) return written;
  std::filesystem::path data_path = png_path;
  data_path.replace_extension(".json");
  if (Status written = write_file_atomically(data_path, to_json(spec).dump() + "\n"); !written)
    return written;
  return run_gnuplot(script_path);
}

}  // namespace camlab::analysis
