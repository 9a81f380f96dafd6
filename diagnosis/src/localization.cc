// Localize: the decompositions of localization.h.
#include "graybox/diagnosis/localization.h"
#include "graybox/util/matrix_rows.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "spectrum.h"

namespace graybox::diagnosis {
namespace {

using estimators::SplitEvaluation;
using models::SignalRole;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Num(double v, int digits = 4) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
  return buf;
}
std::string Percent(double share) { return Num(100.0 * share, 3) + " %"; }

// The used samples of one split: its rows in the split, their residual and regime signals.
struct UsedSplit {
  const SplitEvaluation* eval = nullptr;
  std::vector<int> rows;  // rows of the split used (finite residual and signals)
  int offset = 0;         // index of its first used sample in the pooled arrays
};

void CheckSizes(const models::StateSpaceModel& model, const Eigen::VectorXd& values,
                const SplitEvaluation& s) {
  const std::string where = "Localize: split '" + s.name + "': ";
  const auto n = s.time.size();
  auto check = [&](const char* what, Eigen::Index rows, Eigen::Index cols, Eigen::Index want_cols,
                   const char* cols_what) {
    if (rows != n) {
      throw std::invalid_argument(where + what + " has " + std::to_string(rows) +
                                  " rows; expected " + std::to_string(n) +
                                  " (the samples of time)");
    }
    if (cols != want_cols) {
      throw std::invalid_argument(where + what + " has " + std::to_string(cols) +
                                  " columns; expected " + std::to_string(want_cols) + " (" +
                                  cols_what + ")");
    }
  };
  check("measured", s.measured.rows(), s.measured.cols(), model.NumOutputs(),
        "the model's outputs");
  check("simulated", s.simulated.rows(), s.simulated.cols(), model.NumOutputs(),
        "the model's outputs");
  check("states", s.states.rows(), s.states.cols(), model.NumStates(), "the model's states");
  check("inputs", s.inputs.rows(), s.inputs.cols(), model.NumInputs(), "the model's inputs");
  if (values.size() != model.NumParameters()) {
    throw std::invalid_argument("Localize: values has " + std::to_string(values.size()) +
                                " entries; expected " + std::to_string(model.NumParameters()) +
                                " (the model's parameters)");
  }
}

// Quantile edges (num_bins + 1, duplicates merged) of the values x.
std::vector<double> QuantileEdges(std::vector<double> x, int num_bins) {
  std::sort(x.begin(), x.end());
  std::vector<double> edges;
  const int n = static_cast<int>(x.size());
  for (int b = 0; b <= num_bins; ++b) {
    const double pos = static_cast<double>(b) / num_bins * (n - 1);
    const int lo = static_cast<int>(std::floor(pos));
    const int hi = std::min(lo + 1, n - 1);
    const double q = x[lo] + (pos - lo) * (x[hi] - x[lo]);
    if (edges.empty() || q > edges.back()) edges.push_back(q);
  }
  return edges;
}

// Bin of v among the edges [e0, e1), [e1, e2), ..., [e_{m-1}, e_m] (clamped).
int BinOf(const std::vector<double>& edges, double v) {
  const int num = static_cast<int>(edges.size()) - 1;
  if (num <= 0) return 0;
  const auto it = std::upper_bound(edges.begin(), edges.end(), v);
  const int b = static_cast<int>(it - edges.begin()) - 1;
  return std::clamp(b, 0, num - 1);
}

// A partition of the pooled samples: group index per sample, labels per group.
struct Partition {
  std::string kind, partition, signal;
  std::vector<int> group;  // per pooled sample
  std::vector<std::string> labels;
  std::vector<double> lower, upper;
};

std::string Range(double lo, double hi, const std::string& unit) {
  return "[" + Num(lo) + ", " + Num(hi) + "]" + (unit.empty() ? "" : " " + unit);
}

// Velocity partitions: speed (reversal, near zero, quantile bins of |v|) and direction.
void VelocityPartitions(const std::string& name, const std::string& unit,
                        const std::vector<UsedSplit>& used, const Eigen::VectorXd& v,
                        const LocalizationOptions& options, std::vector<Partition>* out,
                        std::vector<std::string>* notes) {
  const int n = static_cast<int>(v.size());
  const double vmax = v.cwiseAbs().maxCoeff();
  if (!(vmax > 0.0)) {
    notes->push_back("velocity '" + name + "' is zero on every used sample: no speed regimes");
    return;
  }
  const double band = options.near_zero_fraction * vmax;
  constexpr int kReversal = 0, kNearZero = 1;
  std::vector<int> group(n, -1);
  // Reversals: transits from one side of the band to the other, within each split.
  for (const UsedSplit& s : used) {
    const int len = static_cast<int>(s.rows.size());
    int last_side = 0, last_index = -1;
    for (int i = 0; i < len; ++i) {
      const double x = v[s.offset + i];
      const int side = x > band ? 1 : (x < -band ? -1 : 0);
      if (side == 0) continue;
      if (last_side != 0 && side != last_side) {
        const int from = std::max(0, last_index - options.reversal_samples);
        const int to = std::min(len - 1, i + options.reversal_samples);
        for (int k = from; k <= to; ++k) group[s.offset + k] = kReversal;
      }
      last_side = side;
      last_index = i;
    }
  }
  std::vector<double> rest;
  for (int k = 0; k < n; ++k) {
    if (group[k] == kReversal) continue;
    if (std::abs(v[k]) <= band) {
      group[k] = kNearZero;
    } else {
      rest.push_back(std::abs(v[k]));
    }
  }
  Partition speed;
  speed.kind = "regime";
  speed.partition = name + " speed";
  speed.signal = name;
  speed.labels = {name + " reversal (transit through " + Range(-band, band, unit) + " +-" +
                      std::to_string(options.reversal_samples) + " samples)",
                  name + " in " + Range(-band, band, unit) + " (near zero)"};
  speed.lower = {-band, -band};
  speed.upper = {band, band};
  if (!rest.empty()) {
    const std::vector<double> edges = QuantileEdges(rest, options.num_bins);
    const int num = std::max(1, static_cast<int>(edges.size()) - 1);
    for (int b = 0; b < num; ++b) {
      const double lo = edges[b], hi = edges.size() > 1 ? edges[b + 1] : edges[0];
      speed.labels.push_back("|" + name + "| in " + Range(lo, hi, unit) + " (bin " +
                             std::to_string(b + 1) + "/" + std::to_string(num) + ")");
      speed.lower.push_back(lo);
      speed.upper.push_back(hi);
    }
    for (int k = 0; k < n; ++k) {
      if (group[k] < 0) group[k] = 2 + BinOf(edges, std::abs(v[k]));
    }
  }
  speed.group = group;
  out->push_back(speed);

  Partition direction;
  direction.kind = "regime";
  direction.partition = name + " direction";
  direction.signal = name;
  direction.labels = {name + " > 0" + (unit.empty() ? "" : " " + unit) + " (moving +)",
                      name + " <= 0" + (unit.empty() ? "" : " " + unit) + " (moving - or at rest)"};
  direction.lower = {0.0, -vmax};
  direction.upper = {vmax, 0.0};
  direction.group.resize(n);
  for (int k = 0; k < n; ++k) direction.group[k] = v[k] > 0.0 ? 0 : 1;
  out->push_back(direction);
}

void LevelPartition(const std::string& name, const std::string& unit, const Eigen::VectorXd& x,
                    const LocalizationOptions& options, std::vector<Partition>* out,
                    std::vector<std::string>* notes) {
  const std::vector<double> values(x.data(), x.data() + x.size());
  const std::vector<double> edges = QuantileEdges(values, options.num_bins);
  if (edges.size() < 2) {
    notes->push_back("signal '" + name + "' is constant on the used samples: no level regimes");
    return;
  }
  Partition p;
  p.kind = "regime";
  p.partition = name + " level";
  p.signal = name;
  const int num = static_cast<int>(edges.size()) - 1;
  for (int b = 0; b < num; ++b) {
    p.labels.push_back(name + " in " + Range(edges[b], edges[b + 1], unit) + " (bin " +
                       std::to_string(b + 1) + "/" + std::to_string(num) + ")");
    p.lower.push_back(edges[b]);
    p.upper.push_back(edges[b + 1]);
  }
  p.group.resize(x.size());
  for (Eigen::Index k = 0; k < x.size(); ++k) p.group[k] = BinOf(edges, x[k]);
  out->push_back(p);
}

LocalizationEntry MakeEntry(const std::string& channel, const std::string& kind,
                            const std::string& partition, const std::string& signal,
                            const std::string& label, double energy_share, double sample_share,
                            double lower, double upper) {
  LocalizationEntry e;
  e.channel = channel;
  e.kind = kind;
  e.partition = partition;
  e.signal = signal;
  e.label = label;
  e.energy_share = energy_share;
  e.sample_share = sample_share;
  e.concentration = sample_share > 0.0 ? energy_share / sample_share : 0.0;
  e.score =
      energy_share > 0.0 && e.concentration > 0.0 ? energy_share * std::log(e.concentration) : 0.0;
  e.lower = lower;
  e.upper = upper;
  return e;
}

}  // namespace

void LocalizationOptions::Validate() const {
  auto fail = [](const std::string& field, const std::string& expected, double got) {
    throw std::invalid_argument("LocalizationOptions::" + field + ": expected " + expected +
                                ", got " + Num(got, 6));
  };
  if (num_windows < 1) fail("num_windows", ">= 1", num_windows);
  if (num_bins < 1) fail("num_bins", ">= 1", num_bins);
  if (!(near_zero_fraction >= 0.0 && near_zero_fraction < 1.0)) {
    fail("near_zero_fraction", "a number in [0, 1)", near_zero_fraction);
  }
  if (reversal_samples < 0) fail("reversal_samples", ">= 0", reversal_samples);
  if (max_lag < 1) fail("max_lag", ">= 1", max_lag);
  if (num_bands < 1) fail("num_bands", ">= 1", num_bands);
  if (!(confidence > 0.0 && confidence < 1.0)) fail("confidence", "a number in (0, 1)", confidence);
}

double NormalQuantileTwoSided(double confidence) {
  if (!(confidence > 0.0 && confidence < 1.0)) {
    throw std::invalid_argument("NormalQuantileTwoSided: expected a confidence in (0, 1), got " +
                                Num(confidence, 6));
  }
  // P(|Z| > z) = erfc(z / sqrt(2)) = 1 - confidence; bisection on the monotone erfc.
  const double target = 1.0 - confidence;
  double lo = 0.0, hi = 40.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (std::erfc(mid / std::sqrt(2.0)) > target) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

std::vector<LocalizationEntry> Localization::Entries(const std::string& kind,
                                                     const std::string& channel) const {
  std::vector<LocalizationEntry> out;
  for (const LocalizationEntry& e : entries) {
    if (e.kind == kind && (channel.empty() || e.channel == channel)) out.push_back(e);
  }
  return out;
}

Localization Localize(const models::StateSpaceModel& model, const Eigen::VectorXd& values,
                      const std::vector<SplitEvaluation>& splits,
                      const LocalizationOptions& options) {
  options.Validate();
  if (splits.empty()) {
    throw std::invalid_argument("Localize: expected at least one split evaluation, got none");
  }
  Localization loc;
  loc.options = options;
  loc.z = NormalQuantileTwoSided(options.confidence);

  // ---- the used splits ----
  std::vector<const SplitEvaluation*> chosen;
  for (const SplitEvaluation& s : splits) {
    if (s.role != estimators::SplitRole::kEstimation) chosen.push_back(&s);
  }
  if (chosen.empty()) {
    loc.used_all_splits = true;
    loc.notes.push_back(
        "no validation or test split: every split was used (an in-sample residual)");
    for (const SplitEvaluation& s : splits) chosen.push_back(&s);
  }
  const int ny = model.NumOutputs();
  const int nu = model.NumInputs();
  const int min_samples = std::max(options.num_windows, 2);
  for (const SplitEvaluation* s : chosen) {
    CheckSizes(model, values, *s);
    if (s->time.size() < min_samples) {
      throw std::invalid_argument("Localize: split '" + s->name + "' has " +
                                  std::to_string(s->time.size()) + " samples; expected at least " +
                                  std::to_string(min_samples) + " (num_windows and 2)");
    }
  }

  // ---- regime signals along the simulated trajectories ----
  std::vector<std::string> regime_names;
  std::vector<SignalRole> regime_roles;
  std::vector<std::string> regime_units;
  for (const models::SignalDescription& sig : model.signals) {
    const SignalRole r = sig.info.role;
    if (r == SignalRole::kVelocity || r == SignalRole::kPosition || r == SignalRole::kForce ||
        r == SignalRole::kAcceleration || r == SignalRole::kPressure) {
      regime_names.push_back(sig.info.name);
      regime_roles.push_back(r);
      regime_units.push_back(sig.info.unit);
    }
  }
  loc.regime_signals = regime_names;
  const int nr = static_cast<int>(regime_names.size());
  std::vector<Eigen::MatrixXd> signals_of(chosen.size());
  if (nr > 0) {
    for (size_t i = 0; i < chosen.size(); ++i) {
      signals_of[i] =
          model.EvaluateSignals(regime_names, chosen[i]->states, chosen[i]->inputs, values);
    }
  }

  // ---- pooled used samples ----
  std::vector<UsedSplit> used(chosen.size());
  int total = 0;
  for (size_t i = 0; i < chosen.size(); ++i) {
    const SplitEvaluation& s = *chosen[i];
    used[i].eval = &s;
    used[i].offset = total;
    for (Eigen::Index k = 0; k < s.time.size(); ++k) {
      bool ok = (s.measured.row(k) - s.simulated.row(k)).allFinite();
      if (nr > 0) ok = ok && signals_of[i].row(k).allFinite();
      if (ok) {
        used[i].rows.push_back(static_cast<int>(k));
      } else {
        ++loc.num_dropped;
      }
    }
    total += static_cast<int>(used[i].rows.size());
    loc.splits.push_back(s.name);
  }
  if (loc.num_dropped > 0) {
    loc.notes.push_back(std::to_string(loc.num_dropped) +
                        " samples dropped (non-finite residual or regime signal)");
  }
  if (total < 2) {
    throw std::invalid_argument(
        "Localize: expected at least 2 samples with a finite residual, got " +
        std::to_string(total));
  }
  loc.num_samples = total;
  Eigen::MatrixXd y(total, ny), r(total, ny), u(total, nu), sig(total, nr);
  for (const UsedSplit& s : used) {
    for (size_t i = 0; i < s.rows.size(); ++i) {
      const int k = s.rows[i], row = s.offset + static_cast<int>(i);
      y.row(row) = s.eval->measured.row(k);
      r.row(row) = s.eval->measured.row(k) - s.eval->simulated.row(k);
      util::CopyRow(s.eval->inputs, k, u, row);
    }
  }
  for (size_t i = 0; i < used.size(); ++i) {
    for (size_t j = 0; j < used[i].rows.size(); ++j) {
      if (nr > 0) sig.row(used[i].offset + j) = signals_of[i].row(used[i].rows[j]);
    }
  }

  // ---- normalised residual and channels ----
  Eigen::MatrixXd e(total, ny);
  double energy_total = 0.0;
  for (int j = 0; j < ny; ++j) {
    ChannelResidual c;
    c.name = model.outputs[j].name;
    c.unit = model.outputs[j].unit;
    const double mean = y.col(j).mean();
    const double std = std::sqrt((y.col(j).array() - mean).square().mean());
    c.scale = std > 0.0 ? std : 1.0;
    if (!(std > 0.0)) {
      loc.notes.push_back("measured '" + c.name + "' is constant: its residual is not normalised");
    }
    e.col(j) = r.col(j) / c.scale;
    c.energy = e.col(j).squaredNorm();
    c.nrmse = std::sqrt(c.energy / total);
    energy_total += c.energy;
    loc.channels.push_back(c);
  }
  for (ChannelResidual& c : loc.channels) {
    c.energy_share = energy_total > 0.0 ? c.energy / energy_total : 0.0;
    loc.entries.push_back(
        MakeEntry(c.name, "channel", "channels", "", c.name, c.energy_share, 1.0 / ny, kNaN, kNaN));
  }

  // ---- sample partitions: windows and regimes ----
  std::vector<Partition> partitions;
  {
    Partition w;
    w.kind = "window";
    w.partition = "windows";
    w.group.resize(total);
    for (const UsedSplit& s : used) {
      const int n = static_cast<int>(s.eval->time.size());
      const int size = n / options.num_windows;
      for (int b = 0; b < options.num_windows; ++b) {
        const int begin = b * size;
        const int end = b + 1 == options.num_windows ? n : begin + size;
        const double t0 = s.eval->time[begin], t1 = s.eval->time[end - 1];
        w.labels.push_back("split '" + s.eval->name + "' window " + std::to_string(b + 1) + "/" +
                           std::to_string(options.num_windows) + ", t in " + Range(t0, t1, "s"));
        w.lower.push_back(t0);
        w.upper.push_back(t1);
      }
      const int first = static_cast<int>(w.labels.size()) - options.num_windows;
      for (size_t i = 0; i < s.rows.size(); ++i) {
        const int b = std::min(s.rows[i] / std::max(size, 1), options.num_windows - 1);
        w.group[s.offset + i] = first + b;
      }
    }
    partitions.push_back(w);
  }
  for (int i = 0; i < nr; ++i) {
    if (regime_roles[i] == SignalRole::kVelocity) {
      VelocityPartitions(regime_names[i], regime_units[i], used, sig.col(i), options, &partitions,
                         &loc.notes);
    } else {
      LevelPartition(regime_names[i], regime_units[i], sig.col(i), options, &partitions,
                     &loc.notes);
    }
  }
  for (const Partition& p : partitions) {
    const int groups = static_cast<int>(p.labels.size());
    std::vector<int> count(groups, 0);
    for (int g : p.group) ++count[g];
    for (int j = 0; j < ny; ++j) {
      std::vector<double> energy(groups, 0.0);
      for (int k = 0; k < total; ++k) energy[p.group[k]] += e(k, j) * e(k, j);
      const double sum = loc.channels[j].energy;
      for (int g = 0; g < groups; ++g) {
        if (count[g] == 0) continue;
        loc.entries.push_back(MakeEntry(loc.channels[j].name, p.kind, p.partition, p.signal,
                                        p.labels[g], sum > 0.0 ? energy[g] / sum : 0.0,
                                        static_cast<double>(count[g]) / total, p.lower[g],
                                        p.upper[g]));
      }
    }
  }

  // ---- frequency bands ----
  {
    struct Spectrum {
      Eigen::VectorXd freq, residual, output;
    };
    double f_low = std::numeric_limits<double>::infinity(), f_high = 0.0;
    std::vector<std::vector<Spectrum>> spectra(ny);
    for (const UsedSplit& s : used) {
      const int n = static_cast<int>(s.rows.size());
      if (n < 2) continue;
      const Eigen::VectorXd& t = s.eval->time;
      const double dt = (t[t.size() - 1] - t[0]) / static_cast<double>(t.size() - 1);
      const double fs = dt > 0.0 ? 1.0 / dt : 1.0;
      for (int j = 0; j < ny; ++j) {
        Spectrum sp;
        int nfft = 0;
        sp.residual = internal::Periodogram(e.col(j).segment(s.offset, n), &nfft);
        sp.output =
            internal::Periodogram(y.col(j).segment(s.offset, n) / loc.channels[j].scale, &nfft);
        sp.freq = Eigen::VectorXd::LinSpaced(nfft / 2 + 1, 0.0, fs / 2.0);
        f_low = std::min(f_low, fs / nfft);
        f_high = std::max(f_high, fs / 2.0);
        spectra[j].push_back(sp);
      }
    }
    std::vector<double> edges(options.num_bands + 1);
    for (int b = 0; b <= options.num_bands; ++b) {
      edges[b] = f_low * std::pow(f_high / f_low, static_cast<double>(b) / options.num_bands);
    }
    edges.back() = f_high;
    for (int j = 0; j < ny; ++j) {
      std::vector<double> res(options.num_bands, 0.0), out(options.num_bands, 0.0);
      std::vector<int> bins(options.num_bands, 0);
      int all_bins = 0;
      for (const Spectrum& sp : spectra[j]) {
        for (Eigen::Index m = 0; m < sp.freq.size(); ++m) {
          const auto it = std::upper_bound(edges.begin(), edges.end(), sp.freq[m]);
          const int b =
              std::clamp(static_cast<int>(it - edges.begin()) - 1, 0, options.num_bands - 1);
          res[b] += sp.residual[m];
          out[b] += sp.output[m];
          ++bins[b];
          ++all_bins;
        }
      }
      const double res_sum = std::accumulate(res.begin(), res.end(), 0.0);
      const double out_sum = std::accumulate(out.begin(), out.end(), 0.0);
      for (int b = 0; b < options.num_bands; ++b) {
        BandEnergy be;
        be.channel = loc.channels[j].name;
        be.f_low = edges[b];
        be.f_high = edges[b + 1];
        be.residual_share = res_sum > 0.0 ? res[b] / res_sum : 0.0;
        be.output_share = out_sum > 0.0 ? out[b] / out_sum : 0.0;
        be.power_ratio = out[b] > 0.0 ? res[b] / out[b] : kNaN;
        be.num_bins = bins[b];
        loc.bands.push_back(be);
        if (bins[b] == 0) continue;
        loc.entries.push_back(MakeEntry(
            be.channel, "band", "bands", "",
            "f in " + Range(be.f_low, be.f_high, "Hz") + " (residual/output power " +
                Num(be.power_ratio, 3) + ")",
            be.residual_share, static_cast<double>(bins[b]) / all_bins, be.f_low, be.f_high));
      }
    }
  }

  // ---- whiteness and input cross-correlation ----
  {
    const int L = options.max_lag;
    const double bound = loc.z / std::sqrt(static_cast<double>(total));
    Eigen::MatrixXd ec = e, uc = u;  // mean removed per split
    for (const UsedSplit& s : used) {
      const int n = static_cast<int>(s.rows.size());
      if (n == 0) continue;
      for (int j = 0; j < ny; ++j) {
        auto seg = ec.col(j).segment(s.offset, n);
        seg.array() -= seg.mean();
      }
      for (int i = 0; i < nu; ++i) {
        auto seg = uc.col(i).segment(s.offset, n);
        seg.array() -= seg.mean();
      }
    }
    // sum over splits of sum_k a_{k+lag} b_k (pairs within one split).
    auto lagged = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b, int lag) {
      double sum = 0.0;
      for (const UsedSplit& s : used) {
        const int n = static_cast<int>(s.rows.size());
        for (int k = std::max(0, -lag); k < n && k + lag < n; ++k) {
          sum += a[s.offset + k + lag] * b[s.offset + k];
        }
      }
      return sum;
    };
    for (int j = 0; j < ny; ++j) {
      const Eigen::VectorXd ej = ec.col(j);
      const double ee = ej.squaredNorm();
      Whiteness w;
      w.channel = loc.channels[j].name;
      w.bound = bound;
      int outside = 0;
      double worst = -1.0;
      for (int lag = 1; lag <= L; ++lag) {
        const double c = ee > 0.0 ? lagged(ej, ej, lag) / ee : 0.0;
        w.correlation.push_back(c);
        if (std::abs(c) > bound) ++outside;
        if (std::abs(c) > worst) {
          worst = std::abs(c);
          w.worst_lag = lag;
        }
      }
      w.fraction_outside = static_cast<double>(outside) / L;
      loc.whiteness.push_back(w);
      for (int i = 0; i < nu; ++i) {
        const Eigen::VectorXd ui = uc.col(i);
        const double norm = std::sqrt(ee * ui.squaredNorm());
        CrossCorrelation cc;
        cc.channel = w.channel;
        cc.input = model.inputs[i].name;
        cc.bound = bound;
        int out = 0;
        double peak = -1.0;
        for (int lag = -L; lag <= L; ++lag) {
          const double c = norm > 0.0 ? lagged(ej, ui, lag) / norm : 0.0;
          cc.lags.push_back(lag);
          cc.correlation.push_back(c);
          if (std::abs(c) > bound) ++out;
          if (std::abs(c) > peak) {
            peak = std::abs(c);
            cc.peak_lag = lag;
            cc.peak = c;
          }
        }
        cc.fraction_outside = static_cast<double>(out) / (2 * L + 1);
        loc.cross_correlations.push_back(cc);
      }
    }
  }

  std::stable_sort(loc.entries.begin(), loc.entries.end(),
                   [](const LocalizationEntry& a, const LocalizationEntry& b) {
                     if (a.score != b.score) return a.score > b.score;
                     return a.energy_share > b.energy_share;
                   });
  return loc;
}

namespace {

std::string EntryLine(const LocalizationEntry& e) {
  return e.channel + ", " + e.label + ": " + Percent(e.energy_share) + " of the energy in " +
         Percent(e.sample_share) + " of the " + (e.kind == "band" ? "bins" : "samples") + " (x" +
         Num(e.concentration, 3) + ", score " + Num(e.score, 3) + ")";
}

}  // namespace

std::string Localization::BriefReport() const {
  std::ostringstream os;
  os << "gap on";
  for (size_t i = 0; i < splits.size(); ++i) os << (i ? ", '" : " '") << splits[i] << "'";
  if (used_all_splits) os << " (all splits: no validation or test split)";
  os << ":";
  if (!channels.empty()) {
    const auto top = std::max_element(
        channels.begin(), channels.end(),
        [](const ChannelResidual& a, const ChannelResidual& b) { return a.energy < b.energy; });
    os << " " << top->name << " carries " << Percent(top->energy_share)
       << " of the residual energy (NRMSE " << Num(top->nrmse, 3) << ")";
  }
  for (const LocalizationEntry& e : entries) {
    if (e.kind == "channel") continue;
    os << "; top: " << EntryLine(e);
    break;
  }
  int not_white = 0;
  for (const Whiteness& w : whiteness) {
    if (w.fraction_outside > 1.0 - options.confidence) ++not_white;
  }
  os << "; residual " << (not_white > 0 ? "not white" : "white") << " on " << not_white << "/"
     << whiteness.size() << " channels";
  return os.str();
}

std::string Localization::FullReport(int max_entries_per_kind) const {
  std::ostringstream os;
  os << BriefReport() << "\n";
  os << "used samples: " << num_samples << " (" << num_dropped << " dropped)\n";
  os << "channels (residual / std of the measured channel):\n";
  for (const ChannelResidual& c : channels) {
    os << "  " << c.name << " [" << c.unit << "]: std " << Num(c.scale) << ", NRMSE "
       << Num(c.nrmse, 3) << ", " << Percent(c.energy_share) << " of the energy\n";
  }
  for (const char* kind : {"regime", "window", "band"}) {
    os << "top " << kind << " entries:\n";
    int shown = 0;
    for (const LocalizationEntry& e : entries) {
      if (e.kind != kind) continue;
      if (shown++ >= max_entries_per_kind) break;
      os << "  " << EntryLine(e) << "\n";
    }
  }
  os << "frequency bands (residual share, output share, residual/output power):\n";
  for (const BandEnergy& b : bands) {
    os << "  " << b.channel << " " << Range(b.f_low, b.f_high, "Hz") << ": "
       << Percent(b.residual_share) << ", " << Percent(b.output_share) << ", "
       << Num(b.power_ratio, 3) << "\n";
  }
  os << "whiteness (lags 1.." << options.max_lag << ", bound +-" << Num(z, 4) << "/sqrt(N)):\n";
  for (const Whiteness& w : whiteness) {
    os << "  " << w.channel << ": " << Percent(w.fraction_outside) << " of lags outside +-"
       << Num(w.bound, 3) << ", worst lag " << w.worst_lag << " (r "
       << Num(w.correlation.empty() ? 0.0 : w.correlation[w.worst_lag - 1], 3) << ")\n";
  }
  os << "residual-input cross-correlation (lags -" << options.max_lag << ".." << options.max_lag
     << "):\n";
  for (const CrossCorrelation& c : cross_correlations) {
    os << "  " << c.channel << " x " << c.input << ": " << Percent(c.fraction_outside)
       << " of lags outside, peak r " << Num(c.peak, 3) << " at lag " << c.peak_lag << "\n";
  }
  for (const std::string& n : notes) os << "note: " << n << "\n";
  return os.str();
}

}  // namespace graybox::diagnosis
