// A study file -> the workflow's plan (docs/study.md).
#include "shearzone/core/version.hpp"
#include "shearzone/study/study.hpp"

#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "shearzone/core/error.hpp"
#include "shearzone/io/atomic_output.hpp"
#include "shearzone/io/csv.hpp"
#include "shearzone/io/json.hpp"
#include "shearzone/io/toml_config.hpp"
#include "shearzone/sim/scene.hpp"

namespace shearzone::study {
namespace fs = std::filesystem;

namespace {

/// The largest simulation grid a study runs (each point is a simulation of minutes to
/// hours; 1000 scene files are written before anything runs).
constexpr std::size_t kMaxGridPoints = 1000;

// Tags a clip or log carries.
const std::vector<std::string> kClipTags{"N", "phi0_rad", "f_Hz"};
const std::vector<std::string> kLogTags{"N"};

// Options the workflow sets itself, per stage: a study file may not set them.
const std::map<std::string, std::set<std::string>> kReserved{
    {"piv", {"output", "config", "force", "N", "phi0-rad", "f-hz", "quiet", "verbose"}},
    {"profile", {"output", "config", "force", "quiet", "verbose"}},
    {"width", {"output", "config", "force", "quiet", "verbose", "tag"}},
    {"laos", {"output", "config", "force", "quiet", "verbose", "tag"}},
    {"render", {"output", "config", "force", "quiet", "verbose", "format"}},
    {"erf", {"output", "config", "force", "x", "y", "sigma", "group", "quiet", "verbose"}},
    {"power", {"output", "config", "force", "x", "y", "sigma", "group", "subtract-at", "quiet", "verbose"}},
    {"collapse", {"output", "config", "force", "x", "y", "sigma", "group", "quiet", "verbose"}},
};

/// Flags a study table may not set: they make the subcommand do something else than
/// the analysis its job is for.
const std::map<std::string, std::map<std::string, std::string>> kNotInStudy{
    {"laos", {{"inspect", "only lists a log's blocks"}, {"help", "only prints its help"}}},
    {"piv", {{"help", "only prints its help"}}},
    {"profile", {{"help", "only prints its help"}}},
    {"width", {{"help", "only prints its help"}}},
    {"render", {{"help", "only prints its help"}}},
    {"erf", {{"help", "only prints its help"}}},
    {"power", {{"help", "only prints its help"}}},
    {"collapse", {{"help", "only prints its help"}}},
};

bool valid_name(const std::string& s) {
  return !s.empty() && s.size() <= 100 && s.front() != '.' && s.front() != '-' &&
         std::all_of(s.begin(), s.end(), [](char c) {
           return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == '+';
         });
}

class Reader {
 public:
  Reader(const io::TomlConfig& c, KnownOption known, OptionNames names = {}, CheckStage check = {})
      : c_(c), known_(std::move(known)), names_(std::move(names)), check_(std::move(check)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const { c_.fail(key, what); }
  bool has(const std::string& k) const { return c_.has(k); }
  std::string str(const std::string& k) const { return c_.get_string(k); }
  double number(const std::string& k) const { return c_.get_double(k); }

  std::vector<double> numbers(const std::string& k) const {
    std::vector<double> out = c_.get_doubles(k);
    if (out.empty()) fail(k, "an empty list (expected at least one value)");
    return out;
  }
  std::vector<long long> integers(const std::string& k, long long lo, long long hi) const {
    std::vector<long long> out;
    for (const double v : numbers(k)) {
      if (v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi))
        fail(k, fmt::format("{} (expected integers in [{}, {}])", io::format_number(v), lo, hi));
      out.push_back(static_cast<long long>(v));
    }
    return out;
  }
  double positive(const std::string& k, double hi) const {
    const double v = number(k);
    if (!(v > 0.0 && v <= hi)) fail(k, fmt::format("{} (expected 0 < value <= {})", io::format_number(v), hi));
    return v;
  }
  int chain_length(const std::string& k) const {
    const double v = number(k);
    if (v != std::floor(v) || v < 1 || v > 100000)
      fail(k, fmt::format("{} (expected the beads per chain, an integer in [1, 100000])", io::format_number(v)));
    return static_cast<int>(v);
  }
  fs::path existing_file(const std::string& k) const {
    fs::path p = str(k);
    if (p.is_relative()) p = fs::absolute(c_.source()).parent_path() / p;
    p = p.lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(p, ec))
      fail(k, fmt::format("\"{}\": no such file ({})", str(k), p.string()));
    return p;
  }

  /// `<prefix>.<option>` keys -> command-line words for `shearzone <stage>`.
  StageArgs stage_args(const std::string& prefix, const std::string& stage) const {
    StageArgs out;
    std::vector<std::string> keys;
    for (const std::string& key : c_.keys()) {
      if (key.rfind(prefix + ".", 0) != 0) continue;
      keys.push_back(key);
      const std::string opt = key.substr(prefix.size() + 1);
      if (kNotInStudy.count(stage) && kNotInStudy.at(stage).count(opt))
        fail(key, fmt::format("--{} of shearzone {} {} (expected an option of the analysis)", opt, stage_name(stage),
                              kNotInStudy.at(stage).at(opt)));
      if (opt.find('.') != std::string::npos)
        fail(key, fmt::format("a table inside [{}] (expected options of shearzone {})", prefix, stage_name(stage)));
      if (kReserved.at(stage).count(opt))
        fail(key, fmt::format("set by the study itself (expected another option of shearzone {})", stage_name(stage)));
      if (!known_(stage, opt)) {
        std::string best;
        std::size_t bd = 1000;
        if (names_)
          for (const std::string& n : names_(stage))
            if (const std::size_t d = io::edit_distance(opt, n); d < bd) bd = d, best = n;
        fail(key, fmt::format("shearzone {} has no option --{}{}", stage_name(stage), opt,
                              bd <= 3 ? fmt::format(" (did you mean --{}?)", best) : ""));
      }
      const auto& texts = c_.texts(key);
      if (!c_.is_array(key) && (texts[0] == "true" || texts[0] == "false")) {
        // a flag: present when true
        if (texts[0] == "true") out.push_back("--" + opt);
        continue;
      }
      out.push_back("--" + opt);
      std::string joined;
      for (std::size_t i = 0; i < texts.size(); ++i) joined += (i ? "," : "") + texts[i];
      if (texts.empty()) fail(key, "an empty list");
      out.push_back(joined);
    }
    // The values as the subcommand itself checks them, before any job exists (a value it
    // refuses would otherwise become a refused result of every job).
    if (check_ && !keys.empty()) {
      try {
        check_(stage, out);
      } catch (const Error& e) {
        const std::string what = e.what();
        std::string at = keys.front();  // the key whose option the message names
        for (const std::string& k : keys)
          if (what.find("--" + k.substr(prefix.size() + 1)) != std::string::npos) {
            at = k;
            break;
          }
        fail(at, fmt::format("shearzone {} refuses [{}]: {}", stage_name(stage), prefix, what));
      }
    }
    return out;
  }
  static std::string stage_name(const std::string& stage) {
    if (stage == "render") return "sim render";
    if (stage == "erf" || stage == "power") return "fit " + stage;
    if (stage == "collapse") return "collapse erf";
    return stage;
  }

  const io::TomlConfig& c_;
  KnownOption known_;
  OptionNames names_;
  CheckStage check_;
};

/// A tag pattern ("N{N}_phi{phi0_rad}"): literal text, '*' (any text) and {tag} (a
/// number: [-+]?(digits[.digits] | .digits)([eE][-+]?digits)?). Matched by a memoised
/// search over (token, position), O(tokens x stem^2) for any number of wildcards (a
/// backtracking regex took 17 s to over 60 s on several wildcards and long stems);
/// numbers and wildcards take the longest text that lets the rest match.
struct TagPattern {
  struct Token {
    enum Kind { kLiteral, kStar, kNumber } kind;
    std::string text;  ///< the literal, or the tag's name
  };
  std::vector<Token> tokens;
  std::vector<std::string> tags;
};

/// The ends e > pos for which s[pos, e) is a whole number of the tag grammar.
std::vector<std::size_t> number_ends(const std::string& s, std::size_t pos) {
  std::vector<std::size_t> ends;
  std::size_t i = pos;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  const std::size_t int_start = i;
  while (i < s.size() && std::isdigit(static_cast<unsigned char>(s[i]))) ++i;
  const bool int_digits = i > int_start;
  std::vector<std::size_t> mantissa_ends;  // where a mantissa may end
  for (std::size_t k = int_start + 1; k <= i && int_digits; ++k) mantissa_ends.push_back(k);
  if (i < s.size() && s[i] == '.') {
    std::size_t j = i + 1;
    if (int_digits) mantissa_ends.push_back(j);  // "45."
    while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) mantissa_ends.push_back(++j);
  }
  for (std::size_t m : mantissa_ends) {
    ends.push_back(m);
    if (m < s.size() && (s[m] == 'e' || s[m] == 'E')) {
      std::size_t j = m + 1;
      if (j < s.size() && (s[j] == '+' || s[j] == '-')) ++j;
      while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ends.push_back(++j);
    }
  }
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
  return ends;
}

/// Matches `stem` against the pattern; on success `values` holds each tag's text.
bool match_pattern(const TagPattern& tp, const std::string& stem, std::vector<std::string>& values) {
  const std::size_t T = tp.tokens.size(), L = stem.size();
  // can[t][p]: tokens t.. match stem[p..]; 0 unknown, 1 yes, 2 no.
  std::vector<std::uint8_t> can((T + 1) * (L + 1), 0);
  std::function<bool(std::size_t, std::size_t)> rest = [&](std::size_t t, std::size_t p) -> bool {
    std::uint8_t& c = can[t * (L + 1) + p];
    if (c) return c == 1;
    bool ok = false;
    if (t == T) {
      ok = p == L;
    } else {
      const TagPattern::Token& tok = tp.tokens[t];
      if (tok.kind == TagPattern::Token::kLiteral) {
        ok = stem.compare(p, tok.text.size(), tok.text) == 0 && rest(t + 1, p + tok.text.size());
      } else if (tok.kind == TagPattern::Token::kStar) {
        for (std::size_t e = L + 1; e-- > p && !ok;) ok = rest(t + 1, e);
      } else {
        const std::vector<std::size_t> ends = number_ends(stem, p);
        for (auto e = ends.rbegin(); e != ends.rend() && !ok; ++e) ok = rest(t + 1, *e);
      }
    }
    c = ok ? 1 : 2;
    return ok;
  };
  if (!rest(0, 0)) return false;
  // Walk the match again, taking at each token the longest text the rest accepts.
  values.clear();
  std::size_t p = 0;
  for (std::size_t t = 0; t < T; ++t) {
    const TagPattern::Token& tok = tp.tokens[t];
    if (tok.kind == TagPattern::Token::kLiteral) {
      p += tok.text.size();
    } else if (tok.kind == TagPattern::Token::kStar) {
      std::size_t e = L;
      while (!rest(t + 1, e)) --e;
      p = e;
    } else {
      const std::vector<std::size_t> ends = number_ends(stem, p);
      for (auto e = ends.rbegin(); e != ends.rend(); ++e)
        if (rest(t + 1, *e)) {
          values.push_back(stem.substr(p, *e - p));
          p = *e;
          break;
        }
    }
  }
  return true;
}

TagPattern compile_pattern(const Reader& r, const std::string& key, const std::vector<std::string>& allowed) {
  const std::string p = r.str(key);
  TagPattern out;
  auto literal = [&](char c) {
    if (out.tokens.empty() || out.tokens.back().kind != TagPattern::Token::kLiteral)
      out.tokens.push_back({TagPattern::Token::kLiteral, ""});
    out.tokens.back().text += c;
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    const char c = p[i];
    if (c == '{') {
      const std::size_t e = p.find('}', i);
      if (e == std::string::npos) r.fail(key, fmt::format("\"{}\": a '{{' without its '}}'", p));
      const std::string tag = p.substr(i + 1, e - i - 1);
      if (std::find(allowed.begin(), allowed.end(), tag) == allowed.end()) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "{" : ", {") + a + "}";
        r.fail(key, fmt::format("\"{}\": unknown tag {{{}}} (expected {})", p, tag, list));
      }
      if (std::find(out.tags.begin(), out.tags.end(), tag) != out.tags.end())
        r.fail(key, fmt::format("\"{}\": tag {{{}}} appears twice", p, tag));
      out.tags.push_back(tag);
      out.tokens.push_back({TagPattern::Token::kNumber, tag});
      i = e;
    } else if (c == '}') {
      r.fail(key, fmt::format("\"{}\": a '}}' without its '{{'", p));
    } else if (c == '*') {
      if (out.tokens.empty() || out.tokens.back().kind != TagPattern::Token::kStar)  // '**' is '*'
        out.tokens.push_back({TagPattern::Token::kStar, ""});
    } else {
      literal(c);
    }
  }
  if (out.tags.empty()) r.fail(key, fmt::format("\"{}\": no tag (expected e.g. \"N{{N}}_phi{{phi0_rad}}\")", p));
  return out;
}

std::vector<fs::path> glob_files(const Reader& r, const std::string& key) {
  std::string pat = r.str(key);
  fs::path base = fs::absolute(r.c_.source()).parent_path();
  const std::string full = fs::path(pat).is_relative() ? (base / pat).string() : pat;
  glob_t g{};
  const int rc = ::glob(full.c_str(), 0, nullptr, &g);
  std::vector<fs::path> out;
  if (rc == 0)
    for (std::size_t i = 0; i < g.gl_pathc; ++i) {
      std::error_code ec;
      if (fs::is_regular_file(g.gl_pathv[i], ec)) out.push_back(fs::path(g.gl_pathv[i]).lexically_normal());
    }
  globfree(&g);
  if (out.empty()) r.fail(key, fmt::format("\"{}\" matches no file ({})", pat, full));
  std::sort(out.begin(), out.end());
  return out;
}

/// The tags of one globbed file: from the pattern, else the glob table's fixed values.
std::map<std::string, double> file_tags(const Reader& r, const std::string& table, const TagPattern& tp,
                                        const fs::path& file, const std::vector<std::string>& allowed) {
  std::map<std::string, double> tags;
  std::vector<std::string> values;
  const std::string stem = file.stem().string();
  if (!match_pattern(tp, stem, values))
    r.fail(table + ".pattern", fmt::format("\"{}\" does not match the file name {} (its stem \"{}\")",
                                           r.str(table + ".pattern"), file.string(), stem));
  for (std::size_t i = 0; i < tp.tags.size(); ++i) {
    // Overflow (1e999) and underflow (1e-999) are out of range, never infinity or 0.
    errno = 0;
    const double v = std::strtod(values[i].c_str(), nullptr);
    if (errno == ERANGE || !std::isfinite(v))
      r.fail(table + ".pattern", fmt::format("file {}: tag {{{}}} = {} is out of the range of numbers",
                                             file.string(), tp.tags[i], values[i]));
    tags[tp.tags[i]] = v;
  }
  for (const std::string& t : allowed)
    if (r.has(table + "." + t)) {
      if (tags.count(t)) r.fail(table + "." + t, fmt::format("also a tag of the pattern: give it once"));
      tags[t] = r.number(table + "." + t);
    }
  return tags;
}

/// The files of a glob table ([lab.clip_glob], [lab.log_glob]) with their tags; none when
/// the table is absent.
std::vector<std::pair<fs::path, std::map<std::string, double>>> globbed(const Reader& r, const std::string& table,
                                                                      const std::vector<std::string>& allowed) {
  const bool files = r.has(table + ".files"), pattern = r.has(table + ".pattern");
  if (!files && !pattern) return {};
  if (!files || !pattern)
    r.fail(files ? table + ".files" : table + ".pattern",
           fmt::format("[{}] needs both files (a glob) and pattern (the tags in the file name)", table));
  const TagPattern tp = compile_pattern(r, table + ".pattern", allowed);
  std::vector<std::pair<fs::path, std::map<std::string, double>>> out;
  for (const fs::path& f : glob_files(r, table + ".files")) out.emplace_back(f, file_tags(r, table, tp, f, allowed));
  return out;
}

void check_clip_tags(const Reader& r, const std::string& key, const std::string& what, double N, double phi0,
                     double f) {
  if (!(N >= 1 && N <= 100000 && N == std::floor(N)))
    r.fail(key, fmt::format("{}: N = {} (expected the beads per chain, an integer >= 1)", what, io::format_number(N)));
  if (!(phi0 > 0 && phi0 <= 100))
    r.fail(key, fmt::format("{}: phi0_rad = {} (expected 0 < phi0 <= 100)", what, io::format_number(phi0)));
  if (!(f >= 0 && f <= 1000 && std::isfinite(f)))
    r.fail(key, fmt::format("{}: f_Hz = {} (expected 0 < f <= 1000)", what, io::format_number(f)));
}

using io::json_list;
using io::json_number;
using io::json_string;

/// Writes `text` to `path` unless it already holds exactly that (keeps its time stamp,
/// so the workflow sees nothing new).
void write_if_changed(const fs::path& path, const std::string& text) {
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      std::ostringstream old;
      old << in.rdbuf();
      if (old.str() == text) return;
    }
  }
  io::AtomicOutput out(path, true);  // replaces a changed file whole
  out.stream() << text;
  out.commit();
}

/// The cup scene with one grid point's values, named for its messages.
sim::SceneSpec group_scene(sim::SceneSpec spec, const StudySimGroup& g, bool set_chains, bool set_lmax,
                           bool set_angle, long long beads, int threads) {
  if (set_chains) spec.chains.beads_per_chain = g.N;
  if (set_lmax) spec.chains.l_max_m = g.l_max_m;
  if (set_angle) spec.chains.max_angle_deg = g.max_angle_deg;
  spec.fill.seed = g.seed;
  if (beads > 0) spec.fill.count = beads / g.N;
  spec.sim.threads = threads;
  spec.source = "the scene of group " + g.name;
  spec.lines.clear();  // no line of the study's cup scene holds these values
  return spec;
}

}  // namespace

const std::vector<std::string>& study_rules() {
  static const std::vector<std::string> r{"preshear", "branch", "render", "piv", "profile", "width",
                                          "laos", "collect", "fit", "figures"};
  return r;
}

std::string study_branch_name(double phi0_rad) { return sim::SceneProtocol::branch_folder(phi0_rad); }

namespace {

/// Every key of the study file known: the fixed ones, the named tables, the stages'
/// options and the slurm rules (an unknown key names its nearest known one).
void check_known_keys(const io::TomlConfig& c, const Reader& r) {
  const std::set<std::string> fixed{
      "lab.f_Hz", "lab.clip_glob.files", "lab.clip_glob.pattern", "lab.clip_glob.N", "lab.clip_glob.phi0_rad",
      "lab.clip_glob.f_Hz", "lab.log_glob.files", "lab.log_glob.pattern", "lab.log_glob.N",
      "sim.scene", "sim.N", "sim.l_max_m", "sim.max_angle_deg", "sim.seeds", "sim.beads", "sim.phi0_rad",
      "sim.f_Hz", "sim.cycles", "sim.threads", "fits.weights", "slurm.partition", "slurm.time_min",
      "slurm.mem_mb"};
  const std::vector<std::pair<std::string, std::string>> stage_tables{
      {"lab.piv", "piv"},       {"lab.profile", "profile"}, {"lab.width", "width"},   {"lab.laos", "laos"},
      {"sim.render", "render"}, {"sim.piv", "piv"},         {"sim.profile", "profile"}, {"sim.width", "width"},
      {"sim.laos", "laos"},     {"fits.erf", "erf"},        {"fits.power", "power"}, {"fits.collapse", "collapse"}};
  std::vector<std::string> all_known(fixed.begin(), fixed.end());
  for (const auto& [t, st] : stage_tables) all_known.push_back(t + ".<option>");
  for (const std::string& key : c.keys()) {
    if (fixed.count(key)) continue;
    bool ok = false;
    for (const auto& [t, st] : stage_tables) ok = ok || key.rfind(t + ".", 0) == 0;
    for (const char* named : {"lab.clips.", "lab.logs."})
      if (key.rfind(named, 0) == 0) ok = true;
    if (key.rfind("slurm.", 0) == 0) {
      const auto dot = key.find('.', 6);
      const std::string rule = key.substr(6, dot == std::string::npos ? std::string::npos : dot - 6);
      const std::string field = dot == std::string::npos ? "" : key.substr(dot + 1);
      const auto& rules = study_rules();
      if (std::find(rules.begin(), rules.end(), rule) == rules.end()) {
        std::string list;
        for (const auto& x : rules) list += (list.empty() ? "" : ", ") + x;
        r.fail(key, fmt::format("unknown key (expected slurm.partition, slurm.time_min, slurm.mem_mb or a table "
                                "[slurm.RULE], RULE one of {})",
                                list));
      }
      if (field != "partition" && field != "time_min" && field != "mem_mb")
        r.fail(key, "unknown key (expected partition, time_min or mem_mb)");
      ok = true;
    }
    if (!ok) {
      std::string best;
      std::size_t bd = 1000;
      for (const auto& k : all_known)
        if (const std::size_t d = io::edit_distance(key, k); d < bd) bd = d, best = k;
      r.fail(key, fmt::format("unknown key{}", bd <= 3 ? fmt::format(" (did you mean \"{}\"?)", best) : ""));
    }
  }

}

/// The names of the [lab.clips.NAME] and [lab.logs.NAME] tables.
void named_tables(const io::TomlConfig& c, const Reader& r, std::set<std::string>& clip_tables,
                  std::set<std::string>& log_tables) {
  for (const std::string& key : c.keys()) {
    for (const auto& [prefix, set] : {std::pair<std::string, std::set<std::string>*>{"lab.clips.", &clip_tables},
                                      std::pair<std::string, std::set<std::string>*>{"lab.logs.", &log_tables}}) {
      if (key.rfind(prefix, 0) != 0) continue;
      const std::string rest = key.substr(prefix.size());
      const auto dot = rest.find('.');
      if (dot == std::string::npos)
        r.fail(key, fmt::format("a value (expected a table [{}NAME] with its file and tags)", prefix));
      set->insert(rest.substr(0, dot));
    }
  }
}

/// The clips: [lab.clips.NAME] tables and lab.clip_glob (f_Hz by default lab_f); their
/// names go into `names` (every clip's and log's, each once).
void read_clips(const io::TomlConfig& c, const Reader& r, const std::set<std::string>& clip_tables, double lab_f,
                Study& s, std::set<std::string>& names) {
  for (const std::string& name : clip_tables) {
    const std::string t = "lab.clips." + name;
    if (!valid_name(name)) r.fail(t + ".video", fmt::format("clip name \"{}\" (expected up to 100 letters, digits, _ - . +)", name));
    for (const std::string& key : c.keys())
      if (key.rfind(t + ".", 0) == 0) {
        const std::string k = key.substr(t.size() + 1);
        if (k != "video" && k != "N" && k != "phi0_rad" && k != "f_Hz" && k.rfind("piv.", 0) != 0 &&
            k.rfind("profile.", 0) != 0)
          r.fail(key, "unknown key (expected video, N, phi0_rad, f_Hz, or a [piv] or [profile] table of options)");
      }
    for (const char* need : {"video", "N", "phi0_rad"})
      if (!c.has(t + "." + need)) r.fail(t + ".video", fmt::format("clip \"{}\" has no {}", name, need));
    StudyClip clip;
    clip.name = name;
    clip.video = r.existing_file(t + ".video");
    clip.N = r.chain_length(t + ".N");
    clip.phi0_rad = r.number(t + ".phi0_rad");
    clip.f_Hz = c.has(t + ".f_Hz") ? r.number(t + ".f_Hz") : lab_f;
    check_clip_tags(r, t + ".N", "clip " + name, clip.N, clip.phi0_rad, clip.f_Hz);
    clip.piv = r.stage_args(t + ".piv", "piv");
    clip.profile = r.stage_args(t + ".profile", "profile");
    s.clips.push_back(std::move(clip));
  }
  for (auto& [f, tags] : globbed(r, "lab.clip_glob", kClipTags)) {
    if (!tags.count("N") || !tags.count("phi0_rad"))
      r.fail("lab.clip_glob.pattern", "every clip needs N and phi0_rad: put them in the pattern or the table");
    StudyClip clip;
    clip.name = f.stem().string();
    clip.video = f;
    const double N = tags["N"];
    clip.phi0_rad = tags["phi0_rad"];
    clip.f_Hz = tags.count("f_Hz") ? tags["f_Hz"] : lab_f;
    check_clip_tags(r, "lab.clip_glob.pattern", f.string(), N, clip.phi0_rad, clip.f_Hz);
    clip.N = static_cast<int>(N);
    if (!valid_name(clip.name))
      r.fail("lab.clip_glob.files", fmt::format("{}: its name \"{}\" (expected up to 100 letters, digits, _ - . +)",
                                                f.string(), clip.name));
    s.clips.push_back(std::move(clip));
  }
  for (const auto& cl : s.clips)
    if (!names.insert("clip:" + cl.name).second)
      r.fail(c.has("lab.clip_glob.files") ? "lab.clip_glob.files" : "lab.clips." + cl.name + ".video",
             fmt::format("two clips named \"{}\" (each clip's outputs go to lab/clips/NAME)", cl.name));

}

/// The torque logs: [lab.logs.NAME] tables and lab.log_glob.
void read_logs(const io::TomlConfig& c, const Reader& r, const std::set<std::string>& log_tables, Study& s,
               std::set<std::string>& names) {
  for (const std::string& name : log_tables) {
    const std::string t = "lab.logs." + name;
    if (!valid_name(name)) r.fail(t + ".file", fmt::format("log name \"{}\" (expected up to 100 letters, digits, _ - . +)", name));
    for (const std::string& key : c.keys())
      if (key.rfind(t + ".", 0) == 0 && key != t + ".file" && key != t + ".N")
        r.fail(key, "unknown key (expected file and N)");
    for (const char* need : {"file", "N"})
      if (!c.has(t + "." + need)) r.fail(t + ".file", fmt::format("log \"{}\" has no {}", name, need));
    s.logs.push_back({name, r.existing_file(t + ".file"), r.chain_length(t + ".N")});
  }
  for (auto& [f, tags] : globbed(r, "lab.log_glob", kLogTags)) {
    if (!tags.count("N")) r.fail("lab.log_glob.pattern", "every log needs N: put it in the pattern or the table");
    const double N = tags["N"];
    if (!(N >= 1 && N == std::floor(N) && N <= 100000))
      r.fail("lab.log_glob.pattern",
             fmt::format("{}: N = {} (expected an integer >= 1)", f.string(), io::format_number(N)));
    s.logs.push_back({f.stem().string(), f, static_cast<int>(N)});
  }
  for (const auto& l : s.logs)
    if (!valid_name(l.name) || !names.insert("log:" + l.name).second)
      r.fail(c.has("lab.log_glob.files") ? "lab.log_glob.files" : "lab.logs." + l.name + ".file",
             fmt::format("log name \"{}\" used twice or not letters, digits, _ - . + (outputs go to lab/logs/NAME)",
                         l.name));

}

/// The study's cup scene: its keys as values and the world they check to (the container).
struct CupScene {
  sim::SceneSpec spec;
  sim::LoadedScene checked;
};

/// [sim]'s cup scene, checked as the simulator reads it, its branches' amplitudes,
/// frequency, cycles and threads.
CupScene read_sim_scene(const io::TomlConfig& c, const Reader& r, Study& s) {
  if (!c.has("sim.scene")) {
    std::string first;
    for (const std::string& key : c.keys())
      if (first.empty() && key.rfind("sim.", 0) == 0) first = key;
    r.fail(first, "[sim] has no scene (expected sim.scene, a cup scene with [vane], [camera] and [protocol])");
  }
  s.scene = r.existing_file("sim.scene");
  CupScene cup;
  try {
    cup.spec = sim::read_scene(s.scene);
    cup.checked = sim::build_scene(cup.spec, true);
  } catch (const Error& e) {
    throw ConfigError(fmt::format("{} (the scene of {}:{}: key \"sim.scene\")", e.what(), c.source(),
                                  c.line("sim.scene")));
  }
  const sim::LoadedScene& checked = cup.checked;
  if (!checked.protocol || !checked.camera)
    r.fail("sim.scene", fmt::format("{}: a study's cup scene needs [vane], [camera] and [protocol] (docs/sim.md)",
                                    s.scene.string()));
  const sim::SceneProtocol& p = *checked.protocol;
  s.sim_phi0_rad = c.has("sim.phi0_rad") ? r.numbers("sim.phi0_rad") : p.phi0_rad;
  std::set<std::string> branch_names;
  for (const double a : s.sim_phi0_rad) {
    if (!(a > 0 && a <= 100)) r.fail("sim.phi0_rad", fmt::format("{} (expected 0 < phi0 <= 100 rad)", io::format_number(a)));
    if (!branch_names.insert(study_branch_name(a)).second)
      r.fail("sim.phi0_rad", fmt::format("{} appears twice", io::format_number(a)));
  }
  s.sim_f_Hz = c.has("sim.f_Hz") ? r.positive("sim.f_Hz", 1000) : p.f_Hz;
  s.sim_cycles = c.has("sim.cycles") ? r.positive("sim.cycles", 1e6) : p.cycles;
  s.sim_threads = c.has("sim.threads") ? static_cast<int>(r.integers("sim.threads", 1, 256)[0]) : 1;
  // Every branch's drive as `sim --phi0 --f-hz --cycles` will check it, before any job.
  for (const double a : s.sim_phi0_rad) {
    try {
      sim::validate_branch(checked.world->options().sectors, checked.world->options().time_step, 0.0, a,
                           s.sim_f_Hz, s.sim_cycles);
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      // The key at fault: the option the message names (a branch too long: the cycles or
      // the frequency), else the scene whose protocol gave the value.
      const std::vector<const char*> keys = what.rfind("--phi0", 0) == 0   ? std::vector{"sim.phi0_rad"}
                                            : what.rfind("--f-hz", 0) == 0 ? std::vector{"sim.f_Hz"}
                                                                           : std::vector{"sim.cycles", "sim.f_Hz"};
      std::string key = "sim.scene";
      for (const char* k : keys)
        if (key == "sim.scene" && c.has(k)) key = k;
      r.fail(key, fmt::format("the branch at phi0 = {} rad: {}", io::format_number(a), what));
    }
  }
  return cup;
}

/// [sim]'s grid: a group per N x l_max_m x max_angle_deg x seed, each with its scene.
void read_sim_grid(const io::TomlConfig& c, const Reader& r, const CupScene& cup, Study& s) {
  // The scene's own chain values unless the study sets a grid.
  const sim::SceneSpec& tmpl = cup.spec;
  std::vector<long long> Ns = c.has("sim.N") ? r.integers("sim.N", 1, 100000)
                                             : std::vector<long long>{static_cast<long long>(cup.checked.beads_per_chain)};
  std::vector<double> lmax = c.has("sim.l_max_m") ? r.numbers("sim.l_max_m")
                                                  : std::vector<double>{tmpl.chains.l_max_m.value_or(0.0)};
  std::vector<double> angle = c.has("sim.max_angle_deg") ? r.numbers("sim.max_angle_deg")
                                                         : std::vector<double>{tmpl.chains.max_angle_deg.value_or(180.0)};
  std::vector<long long> seeds = c.has("sim.seeds") ? r.integers("sim.seeds", 0, (1LL << 53))
                                                    : std::vector<long long>{tmpl.fill.seed.value_or(1)};
  const long long beads = c.has("sim.beads") ? r.integers("sim.beads", 1, 100000000)[0] : 0;
  for (const double l : lmax)
    if (!(l >= 0)) r.fail("sim.l_max_m", fmt::format("{} (expected >= 0 m)", io::format_number(l)));
  for (const double a : angle)
    if (!(a > 0 && a <= 180)) r.fail("sim.max_angle_deg", fmt::format("{} (expected 0 < angle <= 180 deg)", io::format_number(a)));
  // A value given twice would weigh its branch twice in every fit.
  const auto once = [&](const char* key, std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const auto d = std::adjacent_find(v.begin(), v.end());
    if (d != v.end()) r.fail(key, fmt::format("{} appears twice (a grid lists each value once)", io::format_number(*d)));
  };
  once("sim.N", std::vector<double>(Ns.begin(), Ns.end()));
  once("sim.seeds", std::vector<double>(seeds.begin(), seeds.end()));
  once("sim.l_max_m", lmax);
  once("sim.max_angle_deg", angle);
  const std::size_t points = lmax.size() * angle.size() * Ns.size() * seeds.size();
  if (points > kMaxGridPoints)
    r.fail(seeds.size() > 1 ? "sim.seeds" : c.has("sim.N") ? "sim.N" : c.has("sim.l_max_m") ? "sim.l_max_m" : "sim.scene",
           fmt::format("a grid of {} points (N x l_max_m x max_angle_deg x seeds = {} x {} x {} x {}); at most {}",
                       points, Ns.size(), lmax.size(), angle.size(), seeds.size(), kMaxGridPoints));
  for (const auto N : Ns)
    if (beads > 0 && beads / N < 1)
      r.fail("sim.beads", fmt::format("{} beads make no chain of N = {}", beads, N));
  for (const double l : lmax)
    for (const double a : angle)
      for (const auto N : Ns)
        for (const auto seed : seeds) {
          StudySimGroup g;
          g.N = static_cast<int>(N);
          g.l_max_m = l;
          g.max_angle_deg = a;
          g.seed = seed;
          g.dataset = fmt::format("sim_l{}_a{}", l, a);
          g.name = fmt::format("N{}_l{}_a{}_s{}", N, l, a, seed);
          g.scene = group_scene(tmpl, g, c.has("sim.N"), c.has("sim.l_max_m"), c.has("sim.max_angle_deg"), beads,
                                s.sim_threads);
          s.groups.push_back(std::move(g));
        }
}

/// Each generated scene checked as the simulator will read it, before the output folder
/// exists (a refusal then leaves nothing behind).
void check_group_scenes(const io::TomlConfig& c, const Study& s) {
  for (const auto& g : s.groups) {
    try {
      (void)sim::build_scene(g.scene, true);
    } catch (const Error& e) {
      throw ConfigError(fmt::format("{} (generated from {} by {})", e.what(), s.scene.string(), c.source()));
    }
  }
}

/// The fits' options and weights.
void read_fits(const io::TomlConfig& c, const Reader& r, Study& s) {
  s.fit_erf = r.stage_args("fits.erf", "erf");
  s.fit_power = r.stage_args("fits.power", "power");
  s.collapse_erf = r.stage_args("fits.collapse", "collapse");
  if (c.has("fits.weights")) {
    const std::string w = r.str("fits.weights");
    if (w != "none" && w != "intervals")
      r.fail("fits.weights", fmt::format("\"{}\" (expected \"none\" or \"intervals\")", w));
    s.fit_weigh_intervals = w == "intervals";
  }

}

/// [slurm]: the defaults and each rule's own.
void read_slurm(const io::TomlConfig& c, const Reader& r, Study& s) {
  if (c.has("slurm.partition")) s.slurm.partition = r.str("slurm.partition");
  if (c.has("slurm.time_min")) s.slurm.time_min = r.integers("slurm.time_min", 1, 10000000)[0];
  if (c.has("slurm.mem_mb")) s.slurm.mem_mb = r.integers("slurm.mem_mb", 1, 100000000)[0];
  for (const std::string& rule : study_rules()) {
    StudySlurm::Rule rr;
    const std::string t = "slurm." + rule;
    if (c.has(t + ".partition")) rr.partition = r.str(t + ".partition");
    if (c.has(t + ".time_min")) rr.time_min = r.integers(t + ".time_min", 1, 10000000)[0];
    if (c.has(t + ".mem_mb")) rr.mem_mb = r.integers(t + ".mem_mb", 1, 100000000)[0];
    s.slurm.rules[rule] = rr;
  }
}

}  // namespace

Study load_study(const fs::path& file, const KnownOption& known_option, const OptionNames& option_names,
                 const CheckStage& check_stage) {
  const io::TomlConfig c = io::TomlConfig::load(file);
  const Reader r(c, known_option, option_names, check_stage);
  Study s;
  s.file = fs::absolute(file).lexically_normal();
  check_known_keys(c, r);
  // The lab: clips and torque logs, each name once.
  const double lab_f = c.has("lab.f_Hz") ? r.positive("lab.f_Hz", 1000) : 0.0;
  std::set<std::string> names, clip_tables, log_tables;
  named_tables(c, r, clip_tables, log_tables);
  read_clips(c, r, clip_tables, lab_f, s, names);
  read_logs(c, r, log_tables, s, names);
  s.lab_piv = r.stage_args("lab.piv", "piv");
  s.lab_profile = r.stage_args("lab.profile", "profile");
  s.lab_width = r.stage_args("lab.width", "width");
  s.lab_laos = r.stage_args("lab.laos", "laos");
  // The simulation.
  bool any_sim = false;
  for (const std::string& key : c.keys()) any_sim = any_sim || key.rfind("sim.", 0) == 0;
  if (any_sim) {
    const CupScene cup = read_sim_scene(c, r, s);
    read_sim_grid(c, r, cup, s);
    check_group_scenes(c, s);
    s.sim_render = r.stage_args("sim.render", "render");
    s.sim_piv = r.stage_args("sim.piv", "piv");
    s.sim_profile = r.stage_args("sim.profile", "profile");
    s.sim_width = r.stage_args("sim.width", "width");
    s.sim_laos = r.stage_args("sim.laos", "laos");
  }
  if (s.clips.empty() && s.logs.empty() && s.groups.empty())
    throw ConfigError(fmt::format("{}: no clip, no torque log and no [sim]: nothing to study (docs/study.md)",
                                  c.source()));
  read_fits(c, r, s);
  read_slurm(c, r, s);
  return s;
}

void write_study_plan(const Study& s, const fs::path& out, const fs::path& shearzone, const fs::path& python,
                      const fs::path& scripts) {
  // The generated scenes (load_study checked each as the simulator will read it).
  for (const auto& g : s.groups) {
    std::ostringstream text;
    sim::write_scene(g.scene, text,
                     fmt::format("# generated by `shearzone study run` from {}: {}\n", s.scene.string(), g.name));
    write_if_changed(out / "sim" / g.name / "scene.toml", text.str());
  }
  std::ostringstream j;
  j << "{\n";
  j << "  \"study_file\": " << json_string(s.file.string()) << ",\n";
  j << "  \"shearzone\": " << json_string(shearzone.string()) << ",\n";
  j << "  \"python\": " << json_string(python.string()) << ",\n";
  j << "  \"scripts\": " << json_string(scripts.string()) << ",\n";
  j << "  \"version\": " << json_string(kVersion) << ",\n";
  // lab
  j << "  \"clips\": {";
  for (std::size_t i = 0; i < s.clips.size(); ++i) {
    const auto& cl = s.clips[i];
    StageArgs piv = s.lab_piv;
    piv.insert(piv.end(), cl.piv.begin(), cl.piv.end());
    piv.insert(piv.end(), {"--N", std::to_string(cl.N), "--phi0-rad", io::format_number(cl.phi0_rad)});
    if (cl.f_Hz > 0) piv.insert(piv.end(), {"--f-hz", io::format_number(cl.f_Hz)});
    StageArgs profile = s.lab_profile;
    profile.insert(profile.end(), cl.profile.begin(), cl.profile.end());
    j << (i ? ",\n" : "\n") << "    " << json_string(cl.name) << ": {\"video\": " << json_string(cl.video.string())
      << ", \"N\": " << cl.N << ", \"phi0_rad\": " << json_number(cl.phi0_rad) << ", \"piv\": " << json_list(piv)
      << ", \"profile\": " << json_list(profile) << "}";
  }
  j << (s.clips.empty() ? "},\n" : "\n  },\n");
  j << "  \"logs\": {";
  for (std::size_t i = 0; i < s.logs.size(); ++i)
    j << (i ? ",\n" : "\n") << "    " << json_string(s.logs[i].name) << ": {\"file\": "
      << json_string(s.logs[i].file.string()) << ", \"N\": " << s.logs[i].N << "}";
  j << (s.logs.empty() ? "},\n" : "\n  },\n");
  // simulation
  j << "  \"groups\": {";
  for (std::size_t i = 0; i < s.groups.size(); ++i) {
    const auto& g = s.groups[i];
    j << (i ? ",\n" : "\n") << "    " << json_string(g.name) << ": {\"dataset\": " << json_string(g.dataset)
      << ", \"N\": " << g.N << ", \"l_max_m\": " << json_number(g.l_max_m)
      << ", \"max_angle_deg\": " << json_number(g.max_angle_deg) << ", \"seed\": " << g.seed << "}";
  }
  j << (s.groups.empty() ? "},\n" : "\n  },\n");
  j << "  \"branches\": {";
  for (std::size_t i = 0; i < s.sim_phi0_rad.size(); ++i)
    j << (i ? ", " : "") << json_string(study_branch_name(s.sim_phi0_rad[i])) << ": " << json_number(s.sim_phi0_rad[i]);
  j << "},\n";
  j << "  \"sim_f_Hz\": " << json_number(s.sim_f_Hz) << ", \"sim_cycles\": " << json_number(s.sim_cycles)
    << ", \"sim_threads\": " << s.sim_threads << ",\n";
  // datasets: the lab, and one per (l_max, theta_max) of the grid
  std::map<std::string, std::vector<std::string>> widths, laos;
  std::map<std::string, std::set<int>> Ns;
  for (const auto& cl : s.clips) {
    widths["lab"].push_back("lab/clips/" + cl.name + "/width.csv");
    Ns["lab"].insert(cl.N);
  }
  for (const auto& l : s.logs) laos["lab"].push_back("lab/logs/" + l.name);
  for (const auto& g : s.groups)
    for (const double a : s.sim_phi0_rad) {
      const std::string b = "sim/" + g.name + "/" + study_branch_name(a);
      widths[g.dataset].push_back(b + "/width.csv");
      laos[g.dataset].push_back(b + "/laos");
      Ns[g.dataset].insert(g.N);
    }
  std::set<std::string> datasets;
  for (const auto& [k, v] : widths) datasets.insert(k);
  for (const auto& [k, v] : laos) datasets.insert(k);
  j << "  \"datasets\": {";
  std::size_t i = 0;
  for (const std::string& d : datasets) {
    const bool sim = d != "lab";
    j << (i++ ? ",\n" : "\n") << "    " << json_string(d) << ": {\"widths\": " << json_list(widths[d])
      << ", \"laos\": " << json_list(laos[d]) << ", \"n_N\": " << Ns[d].size()
      << ", \"has_N1\": " << (Ns[d].count(1) ? "true" : "false") << ", \"sim\": " << (sim ? "true" : "false") << "}";
  }
  j << (datasets.empty() ? "},\n" : "\n  },\n");
  j << "  \"args\": {";
  const StageArgs rc_sigma = s.fit_weigh_intervals ? StageArgs{"--sigma", "rc_se_m"} : StageArgs{};
  const std::vector<std::pair<std::string, const StageArgs*>> args{
      {"lab_width", &s.lab_width},     {"lab_laos", &s.lab_laos},
      {"sim_render", &s.sim_render},   {"sim_piv", &s.sim_piv},         {"sim_profile", &s.sim_profile},
      {"sim_width", &s.sim_width},     {"sim_laos", &s.sim_laos},       {"fit_erf", &s.fit_erf},
      {"fit_power", &s.fit_power},     {"collapse_erf", &s.collapse_erf}, {"rc_sigma", &rc_sigma}};
  for (std::size_t k = 0; k < args.size(); ++k)
    j << (k ? ",\n" : "\n") << "    " << json_string(args[k].first) << ": " << json_list(*args[k].second);
  j << "\n  },\n";
  j << "  \"slurm\": {\"partition\": " << json_string(s.slurm.partition) << ", \"time_min\": " << s.slurm.time_min
    << ", \"mem_mb\": " << s.slurm.mem_mb << ", \"rules\": {";
  i = 0;
  for (const auto& [rule, rr] : s.slurm.rules)
    j << (i++ ? ", " : "") << json_string(rule) << ": {\"partition\": " << json_string(rr.partition)
      << ", \"time_min\": " << rr.time_min << ", \"mem_mb\": " << rr.mem_mb << "}";
  j << "}}\n}\n";
  write_if_changed(out / "study.json", j.str());
}

}  // namespace shearzone::study
