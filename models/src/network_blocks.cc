// Network layouts, initialisation and the network block family (see networks.h for the math).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "builtin_blocks.h"
#include "graybox/models/networks.h"
#include "graybox/util/did_you_mean.h"

namespace graybox::models {

// ---- Activations -------------------------------------------------------------------------------

Activation ParseActivation(const std::string& name) {
  if (name == "tanh") return Activation::kTanh;
  if (name == "relu") return Activation::kRelu;
  if (name == "softplus") return Activation::kSoftplus;
  const std::string hint = util::DidYouMean(name, {"tanh", "relu", "softplus"});
  throw std::invalid_argument("unknown activation '" + name + "'" +
                              (hint.empty() ? "" : "; did you mean '" + hint + "'?") +
                              " (expected one of: tanh, relu, softplus)");
}

const char* ActivationName(Activation activation) {
  switch (activation) {
    case Activation::kTanh:
      return "tanh";
    case Activation::kRelu:
      return "relu";
    case Activation::kSoftplus:
      return "softplus";
  }
  return "?";
}

// ---- Normalisation -----------------------------------------------------------------------------

Normalization Normalization::Identity(int n) {
  return Normalization{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Ones(n)};
}

void Normalization::Check(const std::string& what, int n) const {
  if (empty()) return;
  if (mean.size() != n || stddev.size() != n) {
    throw std::invalid_argument(
        what + ": expected " + std::to_string(n) + " means and standard deviations, got " +
        std::to_string(mean.size()) + " and " + std::to_string(stddev.size()));
  }
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(mean[i])) {
      throw std::invalid_argument(what + ": expected a finite mean, got " +
                                  std::to_string(mean[i]) + " for channel " + std::to_string(i));
    }
    if (!(std::isfinite(stddev[i]) && stddev[i] > 0.0)) {
      throw std::invalid_argument(what + ": expected a finite standard deviation > 0, got " +
                                  std::to_string(stddev[i]) + " for channel " + std::to_string(i));
    }
  }
}

Normalization NormalizationFromSamples(const Eigen::MatrixXd& samples) {
  if (samples.rows() == 0) {
    throw std::invalid_argument(
        "NormalizationFromSamples: expected at least one sample (row), got 0");
  }
  if (!samples.allFinite()) {
    throw std::invalid_argument("NormalizationFromSamples: expected finite samples, got NaN/Inf");
  }
  Normalization stats;
  stats.mean = samples.colwise().mean().transpose();
  stats.stddev.resize(samples.cols());
  for (Eigen::Index c = 0; c < samples.cols(); ++c) {
    const double variance = (samples.col(c).array() - stats.mean[c]).square().sum() /
                            static_cast<double>(samples.rows());
    const double s = std::sqrt(variance);
    stats.stddev[c] = s > 0.0 ? s : 1.0;
  }
  return stats;
}

void SetNormalizationOptions(const Normalization& input, const Normalization& output,
                             BlockOptions* options) {
  auto set = [&](const Normalization& n, const std::string& prefix) {
    if (n.empty()) return;
    options->numbers[prefix + "_mean"] =
        std::vector<double>(n.mean.data(), n.mean.data() + n.size());
    options->numbers[prefix + "_std"] =
        std::vector<double>(n.stddev.data(), n.stddev.data() + n.stddev.size());
  };
  set(input, "input");
  set(output, "output");
}

// ---- Deterministic Glorot initialisation ------------------------------------------------------

double UniformUnit(std::mt19937* engine) {
  // genrand_res53: 27 + 26 random bits; every step is exact, so the result is platform-independent.
  const std::uint64_t a = (static_cast<std::uint64_t>((*engine)()) & 0xffffffffu) >> 5;
  const std::uint64_t b = (static_cast<std::uint64_t>((*engine)()) & 0xffffffffu) >> 6;
  return (static_cast<double>(a) * 67108864.0 + static_cast<double>(b)) *
         (1.0 / 9007199254740992.0);
}

double GlorotLimit(int fan_in, int fan_out) {
  if (fan_in < 1 || fan_out < 1) {
    throw std::invalid_argument("GlorotLimit: expected fan_in, fan_out >= 1, got " +
                                std::to_string(fan_in) + ", " + std::to_string(fan_out));
  }
  return std::sqrt(6.0 / static_cast<double>(fan_in + fan_out));
}

double GlorotUniform(int fan_in, int fan_out, std::mt19937* engine) {
  return GlorotLimit(fan_in, fan_out) * (2.0 * UniformUnit(engine) - 1.0);
}

// ---- Dense MLP ---------------------------------------------------------------------------------

void MlpOptions::Check() const {
  if (sizes.size() < 2) {
    throw std::invalid_argument("MLP: expected at least 2 sizes {n_in, ..., n_out}, got " +
                                std::to_string(sizes.size()));
  }
  for (std::size_t k = 0; k < sizes.size(); ++k) {
    if (sizes[k] < 1) {
      throw std::invalid_argument("MLP: expected every size >= 1, got " + std::to_string(sizes[k]) +
                                  " at position " + std::to_string(k));
    }
  }
  const std::size_t num_hidden = sizes.size() - 2;
  if (activations.size() != num_hidden) {
    throw std::invalid_argument("MLP: expected one activation per hidden layer (" +
                                std::to_string(num_hidden) + "), got " +
                                std::to_string(activations.size()));
  }
  if (linear_residual && num_hidden == 0) {
    throw std::invalid_argument(
        "MLP: a linear residual path needs at least one hidden layer (without one it duplicates "
        "the output layer); hint: add a hidden size or turn linear_residual off");
  }
  input.Check("MLP input normalisation", sizes.front());
  output.Check("MLP output normalisation", sizes.back());
}

Mlp::Mlp(MlpOptions options) : options_(std::move(options)) {
  options_.Check();
  int offset = 0;
  for (int k = 0; k < NumLayers(); ++k) {
    layer_offsets_.push_back(offset);
    offset += options_.sizes[k + 1] * (options_.sizes[k] + 1);
  }
  residual_offset_ = offset;
  if (options_.linear_residual) offset += NumInputs() * NumOutputs();
  num_parameters_ = offset;
}

int Mlp::WeightIndex(int layer, int row, int col) const {
  return layer_offsets_[layer] + row * options_.sizes[layer] + col;
}

int Mlp::BiasIndex(int layer, int row) const {
  return layer_offsets_[layer] + options_.sizes[layer + 1] * options_.sizes[layer] + row;
}

int Mlp::ResidualIndex(int row, int col) const {
  return residual_offset_ + row * NumInputs() + col;
}

std::vector<ParameterInfo> Mlp::Parameters(const std::string& prefix, std::mt19937* engine) const {
  std::vector<ParameterInfo> params;
  params.reserve(num_parameters_);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k < NumLayers(); ++k) {
    const int rows = options_.sizes[k + 1];
    const int cols = options_.sizes[k];
    const bool is_output = k + 1 == NumLayers();
    const std::string layer = "l" + std::to_string(k);
    const std::string what = is_output ? "output layer"
                                       : "hidden layer " + std::to_string(k) + " (" +
                                             ActivationName(options_.activations[k]) + ")";
    const std::string source = k == 0 ? "normalised input " : "unit ";
    const std::string target = is_output ? " to output " : " to unit ";
    for (int i = 0; i < rows; ++i) {
      for (int j = 0; j < cols; ++j) {
        ParameterInfo w;
        w.name = prefix + layer + ".w" + std::to_string(i) + "_" + std::to_string(j);
        w.unit = "1";
        w.description = what + " weight from " + source + std::to_string(j) + target +
                        std::to_string(i) + " (Glorot-initialised)";
        w.nominal = GlorotUniform(cols, rows, engine);
        w.neutral = is_output ? 0.0 : nan;
        params.push_back(std::move(w));
      }
    }
    for (int i = 0; i < rows; ++i) {
      ParameterInfo b;
      b.name = prefix + layer + ".b" + std::to_string(i);
      b.unit = "1";
      if (is_output) {
        b.description = "output layer bias of output " + std::to_string(i) +
                        " (normalised units; nominal output_mean / output_std)";
        b.nominal =
            options_.output.empty() ? 0.0 : options_.output.mean[i] / options_.output.stddev[i];
        b.neutral = 0.0;
      } else {
        b.description = what + " bias of unit " + std::to_string(i);
        b.nominal = 0.0;
        b.neutral = nan;
      }
      params.push_back(std::move(b));
    }
  }
  if (options_.linear_residual) {
    for (int i = 0; i < NumOutputs(); ++i) {
      for (int j = 0; j < NumInputs(); ++j) {
        ParameterInfo w;
        w.name = prefix + "lin.w" + std::to_string(i) + "_" + std::to_string(j);
        w.unit = "1";
        w.description = "linear residual weight from normalised input " + std::to_string(j) +
                        " to output " + std::to_string(i) + " (Glorot-initialised)";
        w.nominal = GlorotUniform(NumInputs(), NumOutputs(), engine);
        w.neutral = 0.0;
        params.push_back(std::move(w));
      }
    }
  }
  return params;
}

std::vector<ParameterInfo> Mlp::Parameters(std::uint32_t seed) const {
  std::mt19937 engine(seed);
  return Parameters("", &engine);
}

// ---- GRU ---------------------------------------------------------------------------------------

GruCell::GruCell(int num_inputs, int num_hidden)
    : num_inputs_(num_inputs), num_hidden_(num_hidden) {
  if (num_inputs < 1 || num_hidden < 1) {
    throw std::invalid_argument("GRU cell: expected at least 1 input and 1 hidden unit, got " +
                                std::to_string(num_inputs) + " and " + std::to_string(num_hidden));
  }
}

std::vector<ParameterInfo> GruCell::Parameters(const std::string& prefix,
                                               std::mt19937* engine) const {
  std::vector<ParameterInfo> params(NumParameters());
  const char* gate_names[3] = {"z", "r", "n"};
  const char* gate_descriptions[3] = {"update gate", "reset gate", "candidate state"};
  auto set = [&](int index, std::string name, std::string description, double nominal) {
    ParameterInfo& par = params[index];
    par.name = prefix + std::move(name);
    par.unit = "1";
    par.description = std::move(description);
    par.nominal = nominal;
  };
  for (int g = 0; g < 3; ++g) {
    const Gate gate = static_cast<Gate>(g);
    const std::string gn = gate_names[g];
    const std::string gd = gate_descriptions[g];
    for (int i = 0; i < num_hidden_; ++i) {
      for (int j = 0; j < num_inputs_; ++j) {
        set(InputWeightIndex(gate, i, j), gn + ".w" + std::to_string(i) + "_" + std::to_string(j),
            gd + " input weight from normalised input " + std::to_string(j) + " to unit " +
                std::to_string(i),
            GlorotUniform(num_inputs_, num_hidden_, engine));
      }
    }
    for (int i = 0; i < num_hidden_; ++i) {
      for (int k = 0; k < num_hidden_; ++k) {
        set(RecurrentWeightIndex(gate, i, k),
            gn + ".u" + std::to_string(i) + "_" + std::to_string(k),
            gd + " recurrent weight from state " + std::to_string(k) + " to unit " +
                std::to_string(i),
            GlorotUniform(num_hidden_, num_hidden_, engine));
      }
    }
    for (int i = 0; i < num_hidden_; ++i) {
      set(BiasIndex(gate, i), gn + ".b" + std::to_string(i),
          gd + " bias of unit " + std::to_string(i), 0.0);
    }
  }
  for (int i = 0; i < num_hidden_; ++i) {
    set(HiddenCandidateBiasIndex(i), "n.bh" + std::to_string(i),
        "candidate state bias inside the reset product, unit " + std::to_string(i), 0.0);
  }
  return params;
}

// ---- Blocks ------------------------------------------------------------------------------------

namespace {

// Time constant of the continuous-time GRU: the 4 ms sample period of seed 000 (T_s) and seed 001
// (250 Hz), so that the block is the continuous form of a GRU trained on such data.
constexpr double kDefaultGruTimeConstant = 0.004;
// Signals' typical range: mean -+ this many standard deviations (~95% of Gaussian data).
constexpr double kTypicalRangeStandardDeviations = 2.0;

// Reads and validates the options of one network block type.
class OptionReader {
 public:
  OptionReader(std::string type, const BlockOptions& options, std::vector<std::string> number_keys,
               std::vector<std::string> word_keys)
      : type_(std::move(type)), options_(options) {
    std::vector<std::string> all = number_keys;
    all.insert(all.end(), word_keys.begin(), word_keys.end());
    CheckOptionKeys(type_, options_, all);
    for (const auto& [key, value] : options_.words) {
      if (std::find(word_keys.begin(), word_keys.end(), key) == word_keys.end()) {
        throw Error("option '" + key + "' takes numbers, not a word");
      }
    }
    for (const auto& [key, value] : options_.numbers) {
      if (std::find(number_keys.begin(), number_keys.end(), key) == number_keys.end()) {
        throw Error("option '" + key + "' takes a word, not numbers");
      }
    }
  }

  std::invalid_argument Error(const std::string& message) const {
    return std::invalid_argument("block '" + type_ + "': " + message);
  }

  /// Integers >= `min`; `required` makes a missing key an error with `example` as a hint.
  std::vector<int> Counts(const std::string& key, int min, bool required,
                          const std::string& example) const {
    auto it = options_.numbers.find(key);
    if (it == options_.numbers.end()) {
      if (required) throw Error("option '" + key + "' is required, e.g. " + example);
      return {};
    }
    std::vector<int> counts;
    for (double v : it->second) {
      if (!(v == std::floor(v) && v >= min && v <= 1e6)) {
        throw Error("option '" + key + "': expected integers >= " + std::to_string(min) + ", got " +
                    ToString(v));
      }
      counts.push_back(static_cast<int>(v));
    }
    return counts;
  }

  int Count(const std::string& key, int min, const std::string& example) const {
    const std::vector<int> c = Counts(key, min, true, example);
    if (c.size() != 1) {
      throw Error("option '" + key + "': expected one value, got " + std::to_string(c.size()));
    }
    return c[0];
  }

  std::uint32_t Seed() const {
    auto it = options_.numbers.find("seed");
    if (it == options_.numbers.end()) return 0;
    if (it->second.size() != 1) {
      throw Error("option 'seed': expected one value, got " + std::to_string(it->second.size()));
    }
    const double v = it->second[0];
    if (!(v == std::floor(v) && v >= 0.0 && v <= 4294967295.0)) {
      throw Error("option 'seed': expected an integer in [0, 2^32), got " + ToString(v));
    }
    return static_cast<std::uint32_t>(v);
  }

  bool Flag(const std::string& key, bool fallback) const {
    auto it = options_.numbers.find(key);
    if (it == options_.numbers.end()) return fallback;
    if (it->second.size() != 1 || (it->second[0] != 0.0 && it->second[0] != 1.0)) {
      throw Error("option '" + key + "': expected {0} or {1}");
    }
    return it->second[0] == 1.0;
  }

  double Positive(const std::string& key, double fallback) const {
    auto it = options_.numbers.find(key);
    if (it == options_.numbers.end()) return fallback;
    if (it->second.size() != 1 || !(std::isfinite(it->second[0]) && it->second[0] > 0.0)) {
      throw Error("option '" + key + "': expected one finite value > 0");
    }
    return it->second[0];
  }

  std::string Word(const std::string& key, const std::string& fallback) const {
    auto it = options_.words.find(key);
    if (it == options_.words.end()) return fallback;
    if (it->second.empty()) throw Error("option '" + key + "': expected a non-empty word");
    return it->second;
  }

  /// "tanh" for every hidden layer, or one comma-separated name per hidden layer.
  std::vector<Activation> Activations(int num_hidden) const {
    const std::string word = Word("activation", "tanh");
    std::vector<Activation> result;
    std::stringstream ss(word);
    std::string item;
    try {
      while (std::getline(ss, item, ',')) {
        item.erase(0, item.find_first_not_of(' '));
        item.erase(item.find_last_not_of(' ') + 1);
        result.push_back(ParseActivation(item));
      }
    } catch (const std::invalid_argument& e) {
      throw Error(std::string("option 'activation': ") + e.what());
    }
    if (result.size() == 1) result.assign(num_hidden, result[0]);
    if (static_cast<int>(result.size()) != num_hidden) {
      throw Error("option 'activation': expected one name or one per hidden layer (" +
                  std::to_string(num_hidden) + "), got " + std::to_string(result.size()));
    }
    return result;
  }

  /// "<prefix>_mean" and "<prefix>_std" over n channels, defaulting to 0 and 1.
  Normalization Statistics(const std::string& prefix, int n) const {
    Normalization stats = Normalization::Identity(n);
    auto read = [&](const std::string& key, Eigen::VectorXd* v) {
      auto it = options_.numbers.find(key);
      if (it == options_.numbers.end()) return;
      if (static_cast<int>(it->second.size()) != n) {
        throw Error("option '" + key + "': expected " + std::to_string(n) +
                    " values (one per signal), got " + std::to_string(it->second.size()));
      }
      *v = Eigen::Map<const Eigen::VectorXd>(it->second.data(), n);
    };
    read(prefix + "_mean", &stats.mean);
    read(prefix + "_std", &stats.stddev);
    try {
      stats.Check("option '" + prefix + "_mean'/'" + prefix + "_std'", n);
    } catch (const std::invalid_argument& e) {
      throw Error(e.what());
    }
    return stats;
  }

 private:
  static std::string ToString(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  }
  std::string type_;
  const BlockOptions& options_;
};

SignalInfo MakeSignal(const std::string& name, const std::string& unit,
                      const std::string& description, const Normalization& stats, int channel) {
  const double half = kTypicalRangeStandardDeviations * stats.stddev[channel];
  return SignalInfo{name, unit, description, stats.mean[channel] - half,
                    stats.mean[channel] + half};
}

Normalization Select(const Normalization& stats, const std::vector<int>& channels) {
  Normalization s = Normalization::Identity(static_cast<int>(channels.size()));
  for (std::size_t k = 0; k < channels.size(); ++k) {
    s.mean[static_cast<int>(k)] = stats.mean[channels[k]];
    s.stddev[static_cast<int>(k)] = stats.stddev[channels[k]];
  }
  return s;
}

const std::vector<std::string> kNormalizationKeys = {"input_mean", "input_std", "output_mean",
                                                     "output_std"};

std::vector<std::string> Keys(std::vector<std::string> keys, bool with_normalization = true) {
  if (with_normalization)
    keys.insert(keys.end(), kNormalizationKeys.begin(), kNormalizationKeys.end());
  return keys;
}

// "network.mlp".
class MlpBlock : public BlockBase<MlpBlock> {
 public:
  explicit MlpBlock(const BlockOptions& options) : mlp_(Configure(options, &info_, &seed_)) {
    std::mt19937 engine(seed_);
    info_.parameters = mlp_.Parameters("", &engine);
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    mlp_.Evaluate(a.p, a.u, a.y);
  }

 private:
  // Fills the signal metadata and the seed, and returns the network's options.
  static MlpOptions Configure(const BlockOptions& options, BlockInfo* info, std::uint32_t* seed) {
    const std::string type = "network.mlp";
    const OptionReader reader(type, options, Keys({"sizes", "seed", "linear_residual"}),
                              {"activation", "input_unit", "output_unit"});
    MlpOptions mlp;
    mlp.sizes = reader.Counts("sizes", 1, true, "{2, 16, 16, 1} (n_in, hidden sizes, n_out)");
    if (mlp.sizes.size() < 2) {
      throw reader.Error("option 'sizes': expected at least {n_in, n_out}, got " +
                         std::to_string(mlp.sizes.size()) + " values");
    }
    const int n_in = mlp.sizes.front();
    const int n_out = mlp.sizes.back();
    mlp.activations = reader.Activations(static_cast<int>(mlp.sizes.size()) - 2);
    mlp.linear_residual = reader.Flag("linear_residual", true);
    if (mlp.linear_residual && mlp.sizes.size() == 2) {
      throw reader.Error(
          "option 'linear_residual': needs at least one hidden layer (a network without hidden "
          "layers is already linear); hint: set linear_residual to {0}");
    }
    mlp.input = reader.Statistics("input", n_in);
    mlp.output = reader.Statistics("output", n_out);
    *seed = reader.Seed();
    const std::string input_unit = reader.Word("input_unit", "1");
    const std::string output_unit = reader.Word("output_unit", "1");

    info->type = type;
    info->description = "Dense multilayer perceptron with input normalisation, " +
                        std::to_string(mlp.sizes.size() - 2) +
                        " hidden layer(s), a linear output layer" +
                        (mlp.linear_residual ? " and a linear residual path" : "") +
                        "; output de-normalised. Zero output at the neutral (zero) output weights.";
    info->reference =
        "seed 000 Sec. 2.1 and 2.4 (MLP with residual connection, normalisation); "
        "Glorot and Bengio 2010 (initialisation)";
    for (int j = 0; j < n_in; ++j) {
      info->inputs.push_back(MakeSignal("in" + std::to_string(j), input_unit,
                                        "network input " + std::to_string(j), mlp.input, j));
    }
    for (int i = 0; i < n_out; ++i) {
      info->outputs.push_back(MakeSignal("out" + std::to_string(i), output_unit,
                                         "network output " + std::to_string(i), mlp.output, i));
    }
    return mlp;
  }

  std::uint32_t seed_ = 0;  // set by Configure() (declared before mlp_, so initialised first)
  Mlp mlp_;
};

// "network.per_joint" (seed 000 Model 4) and "network.velocity_positions" (Model 5).
class PerJointBlock : public BlockBase<PerJointBlock> {
 public:
  PerJointBlock(const BlockOptions& options, bool with_positions)
      : with_positions_(with_positions) {
    const std::string type = with_positions ? "network.velocity_positions" : "network.per_joint";
    const OptionReader reader(type, options, Keys({"joints", "hidden", "seed", "linear_residual"}),
                              {"activation"});
    joints_ = reader.Count("joints", 1, "{6}");
    const std::vector<int> hidden =
        reader.Counts("hidden", 1, true, "{16} or {100, 100} (seed 000)");
    const int n = joints_;
    const int num_inputs = with_positions ? 2 * n : n;
    const Normalization input = reader.Statistics("input", num_inputs);
    const Normalization output = reader.Statistics("output", n);
    const std::vector<Activation> activations = reader.Activations(static_cast<int>(hidden.size()));
    const bool linear_residual = reader.Flag("linear_residual", true);
    if (linear_residual && hidden.empty()) {
      throw reader.Error(
          "option 'linear_residual': needs at least one hidden layer; hint: set it to {0}");
    }

    info_.type = type;
    info_.reference = with_positions
                          ? "seed 000 Sec. 2.1 and Table 2, Model 5 \"(vel., all pos.) -> ANN per "
                            "joint\""
                          : "seed 000 Sec. 2.1 and Table 2, Model 4 \"vel. -> ANN per joint\"";
    info_.description =
        with_positions
            ? "One MLP per joint from that joint's velocity and all joint positions to a torque "
              "on that joint (position-dependent load). Zero output at neutral."
            : "One single-input single-output MLP per joint from that joint's velocity to a "
              "torque on that joint (friction-like). Zero output at neutral.";
    for (int j = 0; j < n; ++j) {
      info_.inputs.push_back(MakeSignal("qd" + std::to_string(j + 1), "rad/s",
                                        "velocity of joint " + std::to_string(j + 1), input, j));
    }
    if (with_positions) {
      for (int j = 0; j < n; ++j) {
        info_.inputs.push_back(MakeSignal("q" + std::to_string(j + 1), "rad",
                                          "position of joint " + std::to_string(j + 1), input,
                                          n + j));
      }
    }
    for (int j = 0; j < n; ++j) {
      info_.outputs.push_back(MakeSignal("tau" + std::to_string(j + 1), "N m",
                                         "network torque on joint " + std::to_string(j + 1), output,
                                         j));
    }

    std::mt19937 engine(reader.Seed());
    for (int j = 0; j < n; ++j) {
      MlpOptions mlp;
      mlp.sizes.push_back(with_positions ? n + 1 : 1);
      mlp.sizes.insert(mlp.sizes.end(), hidden.begin(), hidden.end());
      mlp.sizes.push_back(1);
      mlp.activations = activations;
      mlp.linear_residual = linear_residual;
      std::vector<int> channels = {j};
      if (with_positions) {
        for (int c = 0; c < n; ++c) channels.push_back(n + c);
      }
      mlp.input = Select(input, channels);
      mlp.output = Select(output, {j});
      networks_.emplace_back(std::move(mlp));
      const std::vector<ParameterInfo> params =
          networks_.back().Parameters("j" + std::to_string(j + 1) + ".", &engine);
      info_.parameters.insert(info_.parameters.end(), params.begin(), params.end());
    }
  }

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const int n = joints_;
    const int per_network = networks_.front().NumParameters();
    std::vector<Scalar> x(with_positions_ ? n + 1 : 1);
    for (int j = 0; j < n; ++j) {
      x[0] = a.u[j];
      if (with_positions_) {
        for (int c = 0; c < n; ++c) x[c + 1] = a.u[n + c];
      }
      networks_[j].Evaluate(a.p + j * per_network, x.data(), a.y + j);
    }
  }

 private:
  bool with_positions_;
  int joints_ = 0;
  std::vector<Mlp> networks_;  // one per joint (same layout, per-joint normalisation)
};

// "network.gru": continuous-time GRU cell with a linear read-out.
class GruBlock : public BlockBase<GruBlock> {
 public:
  explicit GruBlock(const BlockOptions& options)
      : GruBlock(OptionReader("network.gru", options, Keys({"sizes", "tau", "seed"}),
                              {"input_unit", "output_unit"})) {}

  template <typename Scalar>
  void Compute(const BlockArgs<Scalar>& a) const {
    const int n_in = cell_.NumInputs();
    std::vector<Scalar> x(n_in);
    for (int j = 0; j < n_in; ++j) x[j] = (a.u[j] - input_.mean[j]) / input_.stddev[j];
    GruCellDerivative(cell_, a.p, x.data(), a.x, tau_, a.xdot);
    readout_.Evaluate(a.p + cell_.NumParameters(), a.x, a.y);
  }

 private:
  explicit GruBlock(const OptionReader& reader)
      : cell_(Sizes(reader)[0], Sizes(reader)[1]),
        readout_(ReadoutOptions(Sizes(reader)[1], reader.Statistics("output", Sizes(reader)[2]))),
        input_(reader.Statistics("input", Sizes(reader)[0])),
        tau_(reader.Positive("tau", kDefaultGruTimeConstant)) {
    const std::vector<int> sizes = Sizes(reader);
    const std::string input_unit = reader.Word("input_unit", "1");
    const std::string output_unit = reader.Word("output_unit", "1");
    info_.type = "network.gru";
    info_.description =
        "Continuous-time gated recurrent unit h_dot = (1 - z) o (n - h) / tau (one explicit Euler "
        "step of length tau is the discrete GRU cell) with a linear read-out of the hidden state. "
        "Zero output at the neutral (zero) read-out weights.";
    info_.reference =
        "seed 001 Sec. 2.3 and Fig. 2 (GRU residual model); De Brouwer et al. 2019, GRU-ODE-Bayes "
        "(continuous-time form)";
    for (int j = 0; j < sizes[0]; ++j) {
      info_.inputs.push_back(MakeSignal("in" + std::to_string(j), input_unit,
                                        "GRU input " + std::to_string(j), input_, j));
    }
    for (int i = 0; i < sizes[1]; ++i) {
      info_.states.push_back(SignalInfo{"h" + std::to_string(i), "1",
                                        "GRU hidden state " + std::to_string(i) + ", in (-1, 1)",
                                        -1.0, 1.0});
    }
    for (int i = 0; i < sizes[2]; ++i) {
      info_.outputs.push_back(MakeSignal("out" + std::to_string(i), output_unit,
                                         "read-out " + std::to_string(i), readout_.options().output,
                                         i));
    }
    std::mt19937 engine(reader.Seed());
    info_.parameters = cell_.Parameters("", &engine);
    const std::vector<ParameterInfo> out = readout_.Parameters("out.", &engine);
    info_.parameters.insert(info_.parameters.end(), out.begin(), out.end());
  }

  static std::vector<int> Sizes(const OptionReader& reader) {
    std::vector<int> sizes =
        reader.Counts("sizes", 1, true, "{2, 16, 1} (n_in, hidden state size, n_out)");
    if (sizes.size() != 3) {
      throw reader.Error("option 'sizes': expected {n_in, n_hidden, n_out}, got " +
                         std::to_string(sizes.size()) + " values");
    }
    return sizes;
  }

  static MlpOptions ReadoutOptions(int num_hidden, Normalization output) {
    MlpOptions mlp;
    mlp.sizes = {num_hidden, static_cast<int>(output.size())};
    mlp.linear_residual = false;
    mlp.output = std::move(output);
    return mlp;
  }

  GruCell cell_;
  Mlp readout_;
  Normalization input_;
  double tau_;
};

}  // namespace

namespace internal {

void RegisterNetworkBlocks(BlockRegistry& registry) {
  // Test options: small networks (2 inputs, 5 hidden units, 2 outputs) so the shared suite stays
  // fast, with non-trivial normalisation so that it is covered too.
  BlockOptions mlp;
  mlp.numbers = {{"sizes", {2, 5, 2}},        {"seed", {1}},
                 {"input_mean", {0.5, -1.0}}, {"input_std", {2.0, 0.5}},
                 {"output_mean", {1.0, 0.0}}, {"output_std", {3.0, 0.5}}};
  registry.Register(
      "network.mlp",
      [](const BlockOptions& o) -> std::unique_ptr<Block> { return std::make_unique<MlpBlock>(o); },
      mlp);

  BlockOptions per_joint;
  per_joint.numbers = {
      {"joints", {2}}, {"hidden", {5}}, {"seed", {2}}, {"output_std", {10.0, 5.0}}};
  registry.Register(
      "network.per_joint",
      [](const BlockOptions& o) -> std::unique_ptr<Block> {
        return std::make_unique<PerJointBlock>(o, false);
      },
      per_joint);

  BlockOptions velocity_positions;
  velocity_positions.numbers = {
      {"joints", {2}}, {"hidden", {5}}, {"seed", {3}}, {"input_std", {1.0, 1.5, 2.0, 1.0}}};
  registry.Register(
      "network.velocity_positions",
      [](const BlockOptions& o) -> std::unique_ptr<Block> {
        return std::make_unique<PerJointBlock>(o, true);
      },
      velocity_positions);

  BlockOptions gru;
  gru.numbers = {{"sizes", {2, 5, 2}}, {"seed", {4}}};
  registry.Register(
      "network.gru",
      [](const BlockOptions& o) -> std::unique_ptr<Block> { return std::make_unique<GruBlock>(o); },
      gru);
}

}  // namespace internal
}  // namespace graybox::models
