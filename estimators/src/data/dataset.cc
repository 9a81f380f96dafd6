#include "graybox/estimators/data/dataset.h"
#include "graybox/util/did_you_mean.h"

#include <cassert>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "graybox/models/block.h"

namespace graybox::estimators {
namespace {

const char* GroupWord(ChannelGroup group) {
  switch (group) {
    case ChannelGroup::kInput:
      return "input";
    case ChannelGroup::kOutput:
      return "output";
    case ChannelGroup::kState:
      return "state";
    case ChannelGroup::kStateDerivative:
      return "state derivative";
  }
  return "?";
}

const char* GroupPrefix(ChannelGroup group) {
  switch (group) {
    case ChannelGroup::kInput:
      return "u";
    case ChannelGroup::kOutput:
      return "y";
    case ChannelGroup::kState:
      return "x";
    case ChannelGroup::kStateDerivative:
      return "dx";
  }
  return "?";
}

[[noreturn]] void Fail(const Experiment& e, const std::string& what) {
  throw std::invalid_argument("experiment '" + e.name + "': " + what);
}

void CheckLabels(const Experiment& e, const std::vector<std::string>& labels, Eigen::Index cols,
                 const char* field) {
  if (!labels.empty() && static_cast<Eigen::Index>(labels.size()) != cols) {
    std::ostringstream os;
    os << field << ": expected " << cols << " entries (one per column) or none, got "
       << labels.size();
    Fail(e, os.str());
  }
}

void CheckRows(const Experiment& e, const Eigen::MatrixXd& m, const char* field) {
  if (m.cols() > 0 && m.rows() != e.y.rows()) {
    std::ostringstream os;
    os << field << " has " << m.rows() << " rows: expected " << e.y.rows()
       << " (the number of samples in y)";
    Fail(e, os.str());
  }
}

void CheckFinite(const Experiment& e, ChannelGroup group) {
  const Eigen::MatrixXd& m = e.Signals(group);
  // Column-wise scan: Eigen stores column-major, and the first bad sample of a channel is the
  // useful one to report.
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index k = 0; k < m.rows(); ++k) {
      const double v = m(k, j);
      if (std::isfinite(v)) continue;
      std::ostringstream os;
      os << GroupWord(group) << " '" << e.ChannelName(group, static_cast<int>(j)) << "' (column "
         << j << ") sample " << k;
      const bool time_ok = e.IsUniform() ? std::isfinite(e.dt) && std::isfinite(e.t0)
                                         : k < e.time.size() && std::isfinite(e.time(k));
      if (time_ok) os << " (t = " << e.TimeAt(static_cast<int>(k)) << " s)";
      os << ": expected a finite value, got " << v;
      Fail(e, os.str());
    }
  }
}

}  // namespace

Eigen::VectorXd Experiment::Time() const {
  if (!IsUniform()) return time;
  const Eigen::Index n = y.rows();
  Eigen::VectorXd t(n);
  for (Eigen::Index k = 0; k < n; ++k) t(k) = t0 + static_cast<double>(k) * dt;
  return t;
}

double Experiment::TimeAt(int k) const {
  assert(k >= 0 && k < NumSamples());
  if (!IsUniform()) return time(k);
  return t0 + static_cast<double>(k) * dt;
}

double Experiment::SampleTime() const {
  if (IsUniform()) return dt;
  if (time.size() < 2) {
    Fail(*this, "SampleTime: expected at least 2 time instants to derive a sample time, got " +
                    std::to_string(time.size()));
  }
  return (time(time.size() - 1) - time(0)) / static_cast<double>(time.size() - 1);
}

const Eigen::MatrixXd& Experiment::Signals(ChannelGroup group) const {
  switch (group) {
    case ChannelGroup::kInput:
      return u;
    case ChannelGroup::kOutput:
      return y;
    case ChannelGroup::kState:
      return x;
    case ChannelGroup::kStateDerivative:
      return dx;
  }
  return y;
}

std::string Experiment::ChannelName(ChannelGroup group, int j) const {
  const std::vector<std::string>* names = &y_names;
  if (group == ChannelGroup::kInput) names = &u_names;
  if (group == ChannelGroup::kState || group == ChannelGroup::kStateDerivative) names = &x_names;
  if (j >= 0 && j < static_cast<int>(names->size())) {
    if (group == ChannelGroup::kStateDerivative) return "d(" + (*names)[j] + ")/dt";
    return (*names)[j];
  }
  return GroupPrefix(group) + std::to_string(j);
}

std::string Experiment::ChannelUnit(ChannelGroup group, int j) const {
  const std::vector<std::string>* units = &y_units;
  if (group == ChannelGroup::kInput) units = &u_units;
  if (group == ChannelGroup::kState || group == ChannelGroup::kStateDerivative) units = &x_units;
  if (j < 0 || j >= static_cast<int>(units->size())) return "";
  if (group == ChannelGroup::kStateDerivative) return (*units)[j] + "/s";
  return (*units)[j];
}

int Experiment::ChannelIndex(ChannelGroup group, const std::string& channel_name) const {
  const int cols = static_cast<int>(Signals(group).cols());
  std::vector<std::string> names;
  for (int j = 0; j < cols; ++j) {
    names.push_back(ChannelName(group, j));
    if (names.back() == channel_name) return j;
  }
  std::string message = std::string("no ") + GroupWord(group) + " channel '" + channel_name + "'";
  const std::string hint = util::DidYouMean(channel_name, names);
  if (!hint.empty()) message += "; did you mean '" + hint + "'?";
  Fail(*this, message);
}

void Experiment::Validate() const {
  if (y.rows() == 0) Fail(*this, "expected at least 1 sample, got 0 (y has no rows)");
  if (y.cols() == 0) Fail(*this, "expected at least 1 output channel, got 0 (y has no columns)");
  CheckRows(*this, u, "u");
  CheckRows(*this, x, "x");
  CheckRows(*this, dx, "dx");
  if (dx.cols() > 0 && x.cols() == 0) {
    Fail(*this, "dx is given without x: the state derivatives need the states they belong to");
  }
  if (dx.cols() > 0 && dx.cols() != x.cols()) {
    std::ostringstream os;
    os << "dx has " << dx.cols() << " columns: expected " << x.cols() << " (one per state in x)";
    Fail(*this, os.str());
  }
  CheckLabels(*this, u_names, u.cols(), "u_names");
  CheckLabels(*this, y_names, y.cols(), "y_names");
  CheckLabels(*this, x_names, x.cols(), "x_names");
  CheckLabels(*this, u_units, u.cols(), "u_units");
  CheckLabels(*this, y_units, y.cols(), "y_units");
  CheckLabels(*this, x_units, x.cols(), "x_units");

  const bool has_time = time.size() > 0;
  if (has_time && dt != 0.0) {
    std::ostringstream os;
    os << "expected either a sample time dt or a time vector, got both (dt = " << dt << " s and "
       << time.size() << " time instants); set dt = 0 when giving `time`";
    Fail(*this, os.str());
  }
  if (!has_time) {
    if (!(std::isfinite(dt) && dt > 0.0)) {
      std::ostringstream os;
      os << "expected a sample time dt > 0 s or a time vector, got dt = " << dt
         << " s and no time vector";
      Fail(*this, os.str());
    }
    if (!std::isfinite(t0)) {
      std::ostringstream os;
      os << "expected a finite start time t0, got " << t0;
      Fail(*this, os.str());
    }
  } else {
    if (time.size() != y.rows()) {
      std::ostringstream os;
      os << "time has " << time.size() << " entries: expected " << y.rows()
         << " (the number of samples in y)";
      Fail(*this, os.str());
    }
    for (Eigen::Index k = 0; k < time.size(); ++k) {
      if (!std::isfinite(time(k))) {
        std::ostringstream os;
        os << "time[" << k << "]: expected a finite value, got " << time(k);
        Fail(*this, os.str());
      }
      if (k > 0 && !(time(k) > time(k - 1))) {
        std::ostringstream os;
        os.precision(17);
        os << "time[" << k << "] = " << time(k) << " s after time[" << k - 1
           << "] = " << time(k - 1) << " s: expected strictly increasing time";
        Fail(*this, os.str());
      }
    }
  }
  CheckFinite(*this, ChannelGroup::kInput);
  CheckFinite(*this, ChannelGroup::kOutput);
  CheckFinite(*this, ChannelGroup::kState);
  CheckFinite(*this, ChannelGroup::kStateDerivative);
}

Experiment Slice(const Experiment& experiment, int begin, int end) {
  const int n = experiment.NumSamples();
  if (!(0 <= begin && begin < end && end <= n)) {
    std::ostringstream os;
    os << "Slice: expected 0 <= begin < end <= " << n << ", got [" << begin << ", " << end << ")";
    Fail(experiment, os.str());
  }
  Experiment out;
  out.name = experiment.name + "[" + std::to_string(begin) + ":" + std::to_string(end) + "]";
  const int len = end - begin;
  auto rows = [&](const Eigen::MatrixXd& m) -> Eigen::MatrixXd {
    if (m.cols() == 0) return Eigen::MatrixXd(0, 0);
    return m.middleRows(begin, len);
  };
  out.u = rows(experiment.u);
  out.y = rows(experiment.y);
  out.x = rows(experiment.x);
  out.dx = rows(experiment.dx);
  if (experiment.IsUniform()) {
    out.dt = experiment.dt;
    out.t0 = experiment.t0 + static_cast<double>(begin) * experiment.dt;
  } else {
    out.time = experiment.time.segment(begin, len);
  }
  out.u_names = experiment.u_names;
  out.y_names = experiment.y_names;
  out.x_names = experiment.x_names;
  out.u_units = experiment.u_units;
  out.y_units = experiment.y_units;
  out.x_units = experiment.x_units;
  return out;
}

int Dataset::NumSamples() const {
  int total = 0;
  for (const Experiment& e : experiments) total += e.NumSamples();
  return total;
}

const Experiment& Dataset::Find(const std::string& experiment_name) const {
  std::vector<std::string> names;
  for (const Experiment& e : experiments) {
    if (e.name == experiment_name) return e;
    names.push_back(e.name);
  }
  std::string message = "dataset '" + name + "': no experiment '" + experiment_name + "'";
  const std::string hint = util::DidYouMean(experiment_name, names);
  if (!hint.empty()) message += "; did you mean '" + hint + "'?";
  throw std::invalid_argument(message);
}

void Dataset::Validate() const {
  if (experiments.empty()) {
    throw std::invalid_argument("dataset '" + name + "': expected at least 1 experiment, got 0");
  }
  for (const Experiment& e : experiments) e.Validate();
  const Experiment& first = experiments.front();
  for (const Experiment& e : experiments) {
    if (e.NumInputs() != first.NumInputs() || e.NumOutputs() != first.NumOutputs() ||
        e.NumStates() != first.NumStates()) {
      std::ostringstream os;
      os << "dataset '" << name << "': experiment '" << e.name << "' has (nu, ny, nx) = ("
         << e.NumInputs() << ", " << e.NumOutputs() << ", " << e.NumStates() << "): expected ("
         << first.NumInputs() << ", " << first.NumOutputs() << ", " << first.NumStates()
         << ") like experiment '" << first.name << "'";
      throw std::invalid_argument(os.str());
    }
  }
}

Dataset Split(const Experiment& experiment, const std::vector<SampleRange>& ranges) {
  const int n = experiment.NumSamples();
  std::set<std::string> seen;
  for (size_t i = 0; i < ranges.size(); ++i) {
    const SampleRange& r = ranges[i];
    if (!(0 <= r.begin && r.begin < r.end && r.end <= n)) {
      std::ostringstream os;
      os << "Split: range '" << r.name << "' (#" << i << "): expected 0 <= begin < end <= " << n
         << ", got [" << r.begin << ", " << r.end << ")";
      Fail(experiment, os.str());
    }
    for (size_t j = 0; j < i; ++j) {
      const SampleRange& q = ranges[j];
      if (r.begin < q.end && q.begin < r.end) {
        std::ostringstream os;
        os << "Split: range '" << r.name << "' [" << r.begin << ", " << r.end
           << ") overlaps range '" << q.name << "' [" << q.begin << ", " << q.end
           << "); expected disjoint ranges (use Slice for overlapping windows)";
        Fail(experiment, os.str());
      }
    }
    if (!r.name.empty() && !seen.insert(r.name).second) {
      Fail(experiment, "Split: range name '" + r.name + "' is used twice; expected unique names");
    }
  }
  Dataset out;
  out.name = experiment.name;
  for (const SampleRange& r : ranges) {
    out.experiments.push_back(Slice(experiment, r.begin, r.end));
    if (!r.name.empty()) out.experiments.back().name = r.name;
  }
  return out;
}

}  // namespace graybox::estimators
