#include "control/stability/stability_plots.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>

namespace ptz::control {

bool plotLoop(const std::string& dir, const LoopParams& loop, const ContinuousMargins& m,
              double tau_max_sampled) {
  {
    std::ofstream f(dir + "/open_loop.dat");
    f << "# omega_rad_s magnitude_db phase_deg re im\n";
    for (const auto& p : openLoopResponse(loop, 0.1, 100, 400)) {
      f << p.omega_rad_s << " " << p.magnitude_db << " " << p.phase_deg << " " << p.re << " "
        << p.im << "\n";
    }
  }
  {
    std::ofstream f(dir + "/step.dat");
    f << "# t_s";
    const double taus[] = {0.0, 0.5 * m.tau_max_s, 0.9 * m.tau_max_s, 1.1 * m.tau_max_s};
    std::vector<std::vector<double>> ys;
    for (double tau : taus) {
      f << " tau_" << tau;
      LoopParams l = loop;
      l.delay_s = std::isfinite(tau) ? tau : 0.0;
      ys.push_back(continuousStepResponse(l, 6.0, 0.001));
    }
    f << "\n";
    for (size_t k = 0; k <= 6000; k += 5) {
      f << k * 0.001;
      for (const auto& y : ys) f << " " << (k < y.size() ? y[k] : NAN);
      f << "\n";
    }
  }
  std::ofstream g(dir + "/plots.gp");
  char tau_titles[4][64];
  const double fractions[4] = {0.0, 0.5, 0.9, 1.1};
  for (int i = 0; i < 4; ++i) {
    std::snprintf(tau_titles[i], sizeof(tau_titles[i]), "tau = %.3f s (%.0f %% of tau_max)",
                  fractions[i] * m.tau_max_s, fractions[i] * 100);
  }
  g << "set terminal pngcairo size 900,700 font 'DejaVu Sans,11' noenhanced\n"
    << "set grid\n"
    << "set output '" << dir << "/bode.png'\n"
    << "set multiplot layout 2,1 title 'Open loop G(s) = " << loop.gain << " / (1 + "
    << loop.time_constant_s << " s) e^{-s " << loop.delay_s << "}'\n"
    << "set logscale x\nset xlabel 'angular frequency (rad/s)'\nset ylabel 'magnitude (dB)'\n";
  if (m.has_crossover) {
    g << "set arrow from " << m.crossover_rad_s << ", graph 0 to " << m.crossover_rad_s
      << ", graph 1 nohead dt 2 lc rgb 'red'\n"
      << "set label sprintf('omega_g = %.3f rad/s', " << m.crossover_rad_s << ") at "
      << m.crossover_rad_s << ", graph 0.9 offset 1,0 tc rgb 'red'\n";
  }
  g << "plot '" << dir << "/open_loop.dat' using 1:2 with lines lw 2 title '|G(j omega)|', 0 "
    << "title '0 dB' dt 3 lc rgb 'gray'\n"
    << "set ylabel 'phase (deg)'\n"
    << "set label sprintf('phase margin %.1f deg', " << m.phase_margin_at_delay_deg
    << ") at graph 0.05, graph 0.15\n"
    << "plot '" << dir << "/open_loop.dat' using 1:3 with lines lw 2 title 'arg G(j omega)', -180 "
    << "title '-180 deg' dt 3 lc rgb 'gray'\n"
    << "unset multiplot\nunset arrow\nunset label\nunset logscale x\n"
    << "set output '" << dir << "/nyquist.png'\n"
    << "set title sprintf('Nyquist plot, tau = %.3f s (tau_max %.3f s continuous, %.3f s "
    << "sampled)', " << loop.delay_s << ", " << m.tau_max_s << ", " << tau_max_sampled << ")\n"
    << "set xlabel 'Re G(j omega)'\nset ylabel 'Im G(j omega)'\nset size ratio -1\n"
    << "set xrange [-2:2]\nset yrange [-2:2]\nset parametric\nset trange [0:2*pi]\n"
    << "set label 'critical point -1' at -1,0 point pt 7 lc rgb 'red' offset 1,1\n"
    << "plot '" << dir
    << "/open_loop.dat' using 4:5 with lines lw 2 title 'G(j omega), omega > 0', "
    << "cos(t), sin(t) dt 3 lc rgb 'gray' title 'unit circle'\n"
    << "unset parametric\nunset label\nset size noratio\nset autoscale\n"
    << "set output '" << dir << "/step.png'\n"
    << "set title 'Closed-loop step response (unity feedback), continuous'\n"
    << "set xlabel 'time (s)'\nset ylabel 'output / reference step'\nset yrange [-0.5:2.5]\n"
    << "plot '" << dir << "/step.dat' using 1:2 with lines lw 2 title '" << tau_titles[0] << "', "
    << "'' using 1:3 with lines lw 2 title '" << tau_titles[1] << "', "
    << "'' using 1:4 with lines lw 2 title '" << tau_titles[2] << "', "
    << "'' using 1:5 with lines lw 2 title '" << tau_titles[3] << "'\n";
  g.close();
  return std::system(("gnuplot '" + dir + "/plots.gp'").c_str()) == 0;
}

bool plotSmith(const std::string& dir, const std::vector<SmithCase>& cases, double delay_s,
               double fps) {
  std::ofstream f(dir + "/smith_step.dat");
  std::ofstream g(dir + "/smith.gp");
  g << "set terminal pngcairo size 1150,600 font 'DejaVu Sans,11' noenhanced\nset grid\n"
    << "set key outside right\nset yrange [0:2]\n"
    << "set output '" << dir << "/smith_step.png'\n"
    << "set title 'Smith predictor, tau = " << delay_s << " s, " << fps
    << " Hz: step responses with the plant off from the model'\n"
    << "set xlabel 'time (s)'\nset ylabel 'output / reference step'\nplot ";
  size_t n = 0;
  for (const auto& c : cases) n = std::max(n, c.y.size());
  for (size_t k = 0; k < n; ++k) {
    f << k / fps;
    for (const auto& c : cases) f << " " << (k < c.y.size() ? c.y[k] : NAN);
    f << "\n";
  }
  bool first = true;
  for (size_t i = 0; i < cases.size(); ++i) {
    const auto& c = cases[i];
    // The corners of the +-30 % box and the delay errors; the rest only crowd the plot.
    if (c.k_scale != 1.0 && c.t_scale == 1.0) continue;
    if (c.k_scale == 1.0 && c.t_scale != 1.0) continue;
    char title[96];
    std::snprintf(title, sizeof(title), "plant K x%.1f, T x%.1f, tau x%.1f", c.k_scale, c.t_scale,
                  c.tau_scale);
    g << (first ? "" : ", ") << "'" << dir << "/smith_step.dat' using 1:" << i + 2
      << " with lines lw 2 dt " << (c.tau_scale != 1.0 ? 2 : 1) << " title '" << title << "'";
    first = false;
  }
  g << "\n";
  g.close();
  return std::system(("gnuplot '" + dir + "/smith.gp'").c_str()) == 0;
}

}  // namespace ptz::control
