#include "graybox/expr/codegen.h"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "tape.h"

namespace graybox::expr {

namespace {

// A C identifier usable as the exported function's name: not a keyword, not reserved (leading
// "__" or "_X"), and not a name the generated file declares (gb_*) or takes from <math.h>.
bool IsUsableIdentifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  if (s.size() >= 2 && s[0] == '_' &&
      (s[1] == '_' || std::isupper(static_cast<unsigned char>(s[1])))) {
    return false;
  }
  if (s.rfind("gb_", 0) == 0) return false;
  static const std::set<std::string> kTaken = {
      // C11 keywords.
      "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
      "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
      "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
      "union", "unsigned", "void", "volatile", "while",
      // <math.h> names the generated code uses.
      "pow", "sqrt", "exp", "log", "log1p", "sin", "cos", "tan", "atan", "atan2", "tanh", "fabs",
      "fmax", "erf", "NAN", "INFINITY"};
  return kTaken.count(s) == 0;
}

std::string Literal(double v) {
  if (std::isnan(v)) return "NAN";
  if (std::isinf(v)) return v > 0 ? "INFINITY" : "(-INFINITY)";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  std::string s(buf);
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return v < 0 ? "(" + s + ")" : s;
}

// The C helpers mirror src/op_defs.h exactly.
const char* kPreamble = R"(#include <math.h>
static inline double gb_sigmoid(double x) {
  if (x >= 0.0) return 1.0 / (1.0 + exp(-x));
  const double e = exp(x);
  return e / (1.0 + e);
}
static inline double gb_softplus(double x) { return fmax(x, 0.0) + log1p(exp(-fabs(x))); }
static inline double gb_sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : (x == 0.0 ? 0.0 : x)); }
static inline double gb_min(double a, double b) { return a <= b ? a : (b < a ? b : a + b); }
static inline double gb_max(double a, double b) { return a >= b ? a : (b > a ? b : a + b); }
)";

std::string Statement(const Instruction& in) {
  const std::string a = "w" + std::to_string(in.a);
  const std::string b = "w" + std::to_string(in.b);
  const std::string c = "w" + std::to_string(in.c);
  std::string rhs;
  switch (in.code) {
    case tape_code::kMulAdd:
      return "  w" + std::to_string(in.out) + " = " + a + " * " + b + " + " + c + ";\n";
    case tape_code::kMulSub:
      return "  w" + std::to_string(in.out) + " = " + a + " * " + b + " - " + c + ";\n";
    case tape_code::kSubMul:
      return "  w" + std::to_string(in.out) + " = " + c + " - " + a + " * " + b + ";\n";
    default:
      break;
  }
  switch (static_cast<Op>(in.code)) {
    case Op::kAdd:
      rhs = a + " + " + b;
      break;
    case Op::kSub:
      rhs = a + " - " + b;
      break;
    case Op::kMul:
      rhs = a + " * " + b;
      break;
    case Op::kDiv:
      rhs = a + " / " + b;
      break;
    case Op::kNeg:
      rhs = "-" + a;
      break;
    case Op::kPow:
      rhs = "pow(" + a + ", " + b + ")";
      break;
    case Op::kSqrt:
      rhs = "sqrt(" + a + ")";
      break;
    case Op::kExp:
      rhs = "exp(" + a + ")";
      break;
    case Op::kLog:
      rhs = "log(" + a + ")";
      break;
    case Op::kSin:
      rhs = "sin(" + a + ")";
      break;
    case Op::kCos:
      rhs = "cos(" + a + ")";
      break;
    case Op::kTan:
      rhs = "tan(" + a + ")";
      break;
    case Op::kAtan:
      rhs = "atan(" + a + ")";
      break;
    case Op::kAtan2:
      rhs = "atan2(" + a + ", " + b + ")";
      break;
    case Op::kTanh:
      rhs = "tanh(" + a + ")";
      break;
    case Op::kSigmoid:
      rhs = "gb_sigmoid(" + a + ")";
      break;
    case Op::kSoftplus:
      rhs = "gb_softplus(" + a + ")";
      break;
    case Op::kAbs:
      rhs = "fabs(" + a + ")";
      break;
    case Op::kSign:
      rhs = "gb_sign(" + a + ")";
      break;
    case Op::kMin:
      rhs = "gb_min(" + a + ", " + b + ")";
      break;
    case Op::kMax:
      rhs = "gb_max(" + a + ", " + b + ")";
      break;
    case Op::kErf:
      rhs = "erf(" + a + ")";
      break;
    case Op::kLt:
      rhs = "(" + a + " < " + b + ") ? 1.0 : 0.0";
      break;
    case Op::kLe:
      rhs = "(" + a + " <= " + b + ") ? 1.0 : 0.0";
      break;
    case Op::kEq:
      rhs = "(" + a + " == " + b + ") ? 1.0 : 0.0";
      break;
    case Op::kNe:
      rhs = "(" + a + " != " + b + ") ? 1.0 : 0.0";
      break;
    case Op::kAnd:
      rhs = "(" + a + " != 0.0 && " + b + " != 0.0) ? 1.0 : 0.0";
      break;
    case Op::kOr:
      rhs = "(" + a + " != 0.0 || " + b + " != 0.0) ? 1.0 : 0.0";
      break;
    case Op::kNot:
      rhs = "(" + a + " == 0.0) ? 1.0 : 0.0";
      break;
    case Op::kIfElse:
      rhs = "(" + a + " != 0.0) ? " + b + " : " + c;
      break;
    case Op::kConstant:
    case Op::kSymbol:
      throw std::logic_error("GenerateC: leaf in instruction stream");
  }
  return "  w" + std::to_string(in.out) + " = " + rhs + ";\n";
}

std::string Trim(const std::string& s, std::size_t max_lines) {
  std::istringstream is(s);
  std::string line, out;
  for (std::size_t n = 0; n < max_lines && std::getline(is, line); ++n) out += line + "\n";
  return out;
}

}  // namespace

std::string GenerateC(const Function& f, const std::string& symbol) {
  if (!IsUsableIdentifier(symbol)) {
    throw std::invalid_argument(
        "GenerateC: expected a C identifier that is not a keyword, reserved, or used by the "
        "generated code (gb_*, <math.h> functions), got '" +
        symbol + "'");
  }
  const Tape tape(
      [&] {
        std::vector<std::vector<Expr>> ins;
        for (int i = 0; i < f.NumInputs(); ++i) ins.push_back(f.InputSymbols(i));
        return ins;
      }(),
      [&] {
        std::vector<std::vector<Expr>> outs;
        for (int j = 0; j < f.NumOutputs(); ++j) outs.push_back(f.OutputExprs(j));
        return outs;
      }());
  std::ostringstream os;
  os << "/* Generated by graybox libexpr from Function '" << f.name() << "': " << tape.code().size()
     << " operations, " << tape.num_registers() << " registers. */\n";
  os << kPreamble;
  os << "int " << symbol << "(const double* const* arg, double* const* res) {\n";
  if (tape.num_registers() > 0) {
    os << "  double w0";
    for (int r = 1; r < tape.num_registers(); ++r) os << ", w" << r;
    os << ";\n";
  }
  const auto& in_regs = tape.input_registers();
  for (std::size_t i = 0; i < in_regs.size(); ++i) {
    for (std::size_t k = 0; k < in_regs[i].size(); ++k) {
      if (in_regs[i][k] >= 0) os << "  w" << in_regs[i][k] << " = arg[" << i << "][" << k << "];\n";
    }
  }
  for (const auto& [r, v] : tape.constants()) os << "  w" << r << " = " << Literal(v) << ";\n";
  for (const Instruction& in : tape.code()) os << Statement(in);
  const auto& out_regs = tape.output_registers();
  for (std::size_t j = 0; j < out_regs.size(); ++j) {
    if (out_regs[j].empty()) continue;
    os << "  if (res[" << j << "]) {\n";
    for (std::size_t k = 0; k < out_regs[j].size(); ++k) {
      os << "    res[" << j << "][" << k << "] = w" << out_regs[j][k] << ";\n";
    }
    os << "  }\n";
  }
  os << "  return 0;\n}\n";
  return os.str();
}

namespace {

// 64-bit FNV-1a: a stable hash of the cache key (the same on every run and machine).
std::uint64_t Fnv1a(const std::string& text) {
  std::uint64_t h = 14695981039346656037ULL;
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ULL;
  }
  return h;
}

// The output of a command (its first lines), or "" when it fails.
std::string CommandOutput(const std::string& command) {
  FILE* pipe = popen((command + " 2>/dev/null").c_str(), "r");
  if (pipe == nullptr) return "";
  std::string out;
  char buf[256];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr && out.size() < 4096) out += buf;
  return pclose(pipe) == 0 ? out : "";
}

// The processor as /proc/cpuinfo names it (model and instruction-set flags): code compiled with
// -march=native on one machine must not be loaded on another that shares the cache folder. Read
// once per process.
const std::string& ProcessorIdentity() {
  static const std::string identity = [] {
    std::ifstream in("/proc/cpuinfo");
    std::string model, flags;
    for (std::string line; std::getline(in, line) && (model.empty() || flags.empty());) {
      if (model.empty() && line.rfind("model name", 0) == 0) model = line;
      if (flags.empty() && line.rfind("flags", 0) == 0) flags = line;
    }
    return model + '\n' + flags;
  }();
  return identity;
}

// `compiler -dumpfullversion -dumpmachine` ("" when it fails), asked once per process and
// compiler command: a cache hit then costs no process.
std::string CompilerVersion(const std::string& compiler) {
  static std::mutex mutex;
  static std::map<std::string, std::string> versions;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    const auto it = versions.find(compiler);
    if (it != versions.end()) return it->second;
  }
  std::string version = CommandOutput(compiler + " -dumpfullversion -dumpmachine");
  const std::lock_guard<std::mutex> lock(mutex);
  return versions.emplace(compiler, std::move(version)).first->second;
}

// The cache folder of the options (JitOptions::cache_dir), or "" for none.
std::string CacheFolder(const JitOptions& options) {
  if (!options.use_cache) return "";
  if (!options.cache_dir.empty()) return options.cache_dir;
  if (const char* d = std::getenv("GRAYBOX_JIT_CACHE"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
    return std::string(d) + "/graybox/jit";
  if (const char* d = std::getenv("HOME"); d && *d) return std::string(d) + "/.cache/graybox/jit";
  return "";
}

}  // namespace

bool CompiledFunction::Load(const std::string& library) {
  void* handle = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* err = dlerror();
    fallback_reason_ = std::string("dlopen failed: ") + (err ? err : "unknown error");
    return false;
  }
  library_ = std::shared_ptr<void>(handle, [](void* h) { dlclose(h); });
  native_ = reinterpret_cast<NativeFn>(dlsym(handle, "graybox_function"));
  if (native_ == nullptr) {
    fallback_reason_ = "dlsym found no graybox_function in " + library;
    library_.reset();
    return false;
  }
  fallback_reason_.clear();
  return true;
}

CompiledFunction::CompiledFunction(const Function& f, const JitOptions& options) : function_(f) {
  for (int j = 0; j < f.NumOutputs(); ++j) output_sizes_.push_back(f.OutputSize(j));
  const char* cc_env = std::getenv("CC");
  const std::string compiler =
      !options.compiler.empty() ? options.compiler : (cc_env && *cc_env ? cc_env : "cc");
  const std::string source = GenerateC(f, "graybox_function");
  // The cache: a hit loads the library and is done.
  // keep_files asks for this compilation's files: no cache then.
  std::string cache = options.keep_files ? std::string() : CacheFolder(options);
  if (!cache.empty()) {
    const std::string version = CompilerVersion(compiler);
    std::error_code ec;
    const bool existed = std::filesystem::is_directory(cache, ec);
    if (!existed) std::filesystem::create_directories(cache, ec);
    if (ec || version.empty()) {
      cache.clear();  // no cache folder, or a compiler that does not say its version: compile
    } else {
      // A folder this creates is the user's alone; one that existed keeps its permissions.
      if (!existed) {
        std::filesystem::permissions(cache, std::filesystem::perms::owner_all,
                                     std::filesystem::perm_options::replace, ec);
      }
      char name[32];
      std::snprintf(
          name, sizeof name, "%016llx.so",
          static_cast<unsigned long long>(Fnv1a(source + '\n' + compiler + '\n' + options.flags +
                                                '\n' + version + '\n' + ProcessorIdentity())));
      cache_file_ = cache + "/" + name;
      if (std::filesystem::exists(cache_file_, ec)) {
        if (Load(cache_file_)) {
          from_cache_ = true;
          return;
        }
        std::filesystem::remove(cache_file_, ec);  // unloadable: compiled again below
      }
    }
  }
  std::string dir = options.work_dir;
  bool own_dir = false;
  if (dir.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    std::string templ = std::string(tmp && *tmp ? tmp : "/tmp") + "/graybox_jit_XXXXXX";
    std::vector<char> buf(templ.begin(), templ.end());
    buf.push_back('\0');
    if (mkdtemp(buf.data()) == nullptr) {
      fallback_reason_ = "cannot create a temporary directory from " + templ;
      return;
    }
    dir = buf.data();
    own_dir = true;
  }
  const std::string src = dir + "/function.c";
  const std::string lib = dir + "/function.so";
  const std::string log = dir + "/compile.log";
  {
    std::ofstream out(src);
    out << source;
    if (!out) {
      fallback_reason_ = "cannot write " + src;
      return;
    }
  }
  const std::string cmd = compiler + " " + options.flags + " -fPIC -shared -o '" + lib + "' '" +
                          src + "' -lm > '" + log + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc != 0) {
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    fallback_reason_ = "compiler command failed (exit status " + std::to_string(rc) + "): " + cmd +
                       "\n" + Trim(ss.str(), 10);
  } else if (Load(lib) && !cache_file_.empty()) {
    // Into the cache under a temporary name, then renamed: a reader sees all of it or nothing.
    std::error_code ec;
    static std::atomic<unsigned> counter{0};  // threads of one process compiling the same code
    const std::string tmp =
        cache_file_ + "." + std::to_string(getpid()) + "." + std::to_string(counter++) + ".tmp";
    std::filesystem::copy_file(lib, tmp, std::filesystem::copy_options::overwrite_existing, ec);
    if (!ec) std::filesystem::rename(tmp, cache_file_, ec);
    if (ec) std::filesystem::remove(tmp, ec);
  }
  if (!options.keep_files) {
    std::remove(src.c_str());
    std::remove(lib.c_str());
    std::remove(log.c_str());
    if (own_dir) rmdir(dir.c_str());
  }
}

EvalStatus CompiledFunction::Evaluate(const double* const* inputs, double* const* outputs,
                                      Workspace* ws) const {
  if (native_ == nullptr) return function_.Evaluate(inputs, outputs, ws);
  native_(inputs, outputs);
  EvalStatus status;
  for (std::size_t j = 0; j < output_sizes_.size() && status.ok; ++j) {
    if (outputs[j] == nullptr) continue;
    const double* y = outputs[j];
    const int size = output_sizes_[j];
    // Fast path: sum-free finiteness test over the whole output, details only on failure.
    bool finite = true;
    for (int k = 0; k < size; ++k) finite &= std::isfinite(y[k]);
    if (finite) continue;
    for (int k = 0; k < size; ++k) {
      if (!std::isfinite(outputs[j][k])) {
        status.ok = false;
        status.output = static_cast<int>(j);
        status.index = k;
        status.value = outputs[j][k];
        std::ostringstream os;
        os << "Function '" << function_.name() << "': output '"
           << function_.OutputName(static_cast<int>(j)) << "'[" << k << "] = " << outputs[j][k];
        status.message = os.str();
        break;
      }
    }
  }
  return status;
}

std::vector<Eigen::VectorXd> CompiledFunction::operator()(
    const std::vector<Eigen::VectorXd>& inputs) const {
  if (native_ == nullptr) return function_(inputs);
  if (static_cast<int>(inputs.size()) != function_.NumInputs()) {
    throw std::invalid_argument("CompiledFunction '" + function_.name() + "': expected " +
                                std::to_string(function_.NumInputs()) + " inputs, got " +
                                std::to_string(inputs.size()));
  }
  std::vector<const double*> in(inputs.size());
  for (int i = 0; i < function_.NumInputs(); ++i) {
    if (inputs[i].size() != function_.InputSize(i)) {
      throw std::invalid_argument("CompiledFunction '" + function_.name() + "': input '" +
                                  function_.InputName(i) + "': expected size " +
                                  std::to_string(function_.InputSize(i)) + ", got " +
                                  std::to_string(inputs[i].size()));
    }
    in[i] = inputs[i].data();
  }
  std::vector<Eigen::VectorXd> outputs(function_.NumOutputs());
  std::vector<double*> out(outputs.size());
  for (int j = 0; j < function_.NumOutputs(); ++j) {
    outputs[j].resize(function_.OutputSize(j));
    out[j] = outputs[j].data();
  }
  const EvalStatus status = Evaluate(in.data(), out.data(), nullptr);
  if (!status.ok) throw NonFiniteError(status.message);
  return outputs;
}

}  // namespace graybox::expr
