#include "cli_args.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace cadinterp::cli {

namespace {

std::string format_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Levenshtein distance, for "did you mean" on mistyped option names.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

bool looks_numeric(const std::string& s) {
  double v;
  return parse_double(s, &v);
}

}  // namespace

bool parse_double(const std::string& s, double* out) {
  if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return false;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(v)) return false;
  // strtod accepts hex floats; the tool prints decimals, but a user pasting "0x1p-3" from
  // conformance data gets what it says, which is harmless.
  *out = v;
  return true;
}

bool parse_int(const std::string& s, long long* out) {
  if (s.empty() || std::isspace(static_cast<unsigned char>(s[0]))) return false;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (end != s.c_str() + s.size() || errno == ERANGE) return false;
  *out = v;
  return true;
}

std::vector<std::string> split_list(const std::string& s, char sep) {
  std::vector<std::string> items;
  if (s.empty()) return items;
  std::size_t start = 0;
  for (;;) {
    const std::size_t p = s.find(sep, start);
    items.push_back(s.substr(start, p == std::string::npos ? std::string::npos : p - start));
    if (p == std::string::npos) break;
    start = p + 1;
  }
  return items;
}

ArgParser::ArgParser(std::string program, std::string synopsis, std::string description)
    : program_(std::move(program)),
      synopsis_(std::move(synopsis)),
      description_(std::move(description)) {}

ArgParser::Option& ArgParser::add(const std::string& name, char short_name,
                                  const std::string& metavar, const std::string& help) {
  Option o;
  o.name = name;
  o.short_name = short_name;
  o.metavar = metavar;
  o.help = help;
  options_.push_back(std::move(o));
  return options_.back();
}

ArgParser& ArgParser::flag(const std::string& name, char short_name, const std::string& help,
                           bool* out) {
  Option& o = add(name, short_name, "", help);
  o.takes_value = false;
  o.set = [out](const std::string&) { *out = true; };
  return *this;
}

ArgParser& ArgParser::option(const std::string& name, char short_name, const std::string& metavar,
                             const std::string& help, std::string* out) {
  Option& o = add(name, short_name, metavar, help);
  if (!out->empty()) o.default_text = *out;
  o.set = [out](const std::string& v) { *out = v; };
  return *this;
}

ArgParser& ArgParser::repeated(const std::string& name, char short_name, const std::string& metavar,
                               const std::string& help, std::vector<std::string>* out) {
  Option& o = add(name, short_name, metavar, help + " (may be repeated)");
  o.repeatable = true;
  o.set = [out](const std::string& v) { out->push_back(v); };
  return *this;
}

ArgParser& ArgParser::option(const std::string& name, char short_name, const std::string& metavar,
                             const std::string& help, int* out, int min, int max) {
  Option& o = add(name, short_name, metavar, help);
  o.default_text = std::to_string(*out);
  o.set = [out, min, max, name](const std::string& v) {
    long long n = 0;
    if (!parse_int(v, &n)) throw UsageError("--" + name + " expects an integer, got '" + v + "'");
    if (n < min || n > max)
      throw UsageError("--" + name + " must be in [" + std::to_string(min) + ", " +
                       std::to_string(max) + "], got " + v);
    *out = static_cast<int>(n);
  };
  return *this;
}

ArgParser& ArgParser::option(const std::string& name, char short_name, const std::string& metavar,
                             const std::string& help, double* out, double min, double max) {
  Option& o = add(name, short_name, metavar, help);
  o.default_text = format_number(*out);
  o.set = [out, min, max, name](const std::string& v) {
    double d = 0;
    if (!parse_double(v, &d))
      throw UsageError("--" + name + " expects a finite number, got '" + v + "'");
    if (d < min || d > max)
      throw UsageError("--" + name + " must be in [" + format_number(min) + ", " +
                       format_number(max) + "], got " + v);
    *out = d;
  };
  return *this;
}

ArgParser& ArgParser::choice(const std::string& name, char short_name, const std::string& help,
                             const std::vector<std::string>& choices, std::string* out) {
  std::string metavar;
  for (const std::string& c : choices) metavar += (metavar.empty() ? "" : "|") + c;
  Option& o = add(name, short_name, metavar, help);
  if (!out->empty()) o.default_text = *out;
  o.set = [out, choices, name, metavar](const std::string& v) {
    if (std::find(choices.begin(), choices.end(), v) == choices.end())
      throw UsageError("--" + name + " must be one of " + metavar + ", got '" + v + "'");
    *out = v;
  };
  return *this;
}

ArgParser& ArgParser::required() {
  options_.back().is_required = true;
  options_.back().default_text.clear();
  return *this;
}

ArgParser& ArgParser::show_default(const std::string& text) {
  options_.back().default_text = text;
  return *this;
}

ArgParser& ArgParser::positional(const std::string& name, const std::string& help,
                                 std::string* out) {
  positionals_.push_back({name, help, out});
  return *this;
}

ArgParser& ArgParser::rest(const std::string& name, const std::string& help,
                           std::vector<std::string>* out, std::size_t min_count) {
  rest_name_ = name;
  rest_help_ = help;
  rest_ = out;
  rest_min_ = min_count;
  return *this;
}

ArgParser& ArgParser::epilog(const std::string& text) {
  epilog_ = text;
  return *this;
}

ArgParser::Option* ArgParser::find_long(const std::string& name) {
  for (Option& o : options_)
    if (o.name == name) return &o;
  return nullptr;
}

ArgParser::Option* ArgParser::find_short(char c) {
  for (Option& o : options_)
    if (o.short_name == c) return &o;
  return nullptr;
}

std::string ArgParser::suggest(const std::string& name) const {
  std::string best;
  std::size_t best_d = 3;  // farther than 2 edits is a different word, not a typo
  for (const Option& o : options_) {
    const std::size_t d = edit_distance(name, o.name);
    if (d < best_d) {
      best_d = d;
      best = o.name;
    }
  }
  return best.empty() ? "" : " (did you mean --" + best + "?)";
}

bool ArgParser::seen(const std::string& name) const {
  for (const Option& o : options_)
    if (o.name == name) return o.was_seen;
  return false;
}

bool ArgParser::parse(const std::vector<std::string>& args) {
  // --help wins wherever it is, so that "cadinterp eval --help" works with a broken line too.
  for (const std::string& a : args) {
    if (a == "--") break;
    if (a == "--help" || a == "-h") {
      std::fputs(help().c_str(), stdout);
      return false;
    }
  }
  std::vector<std::string> positional;
  bool options_done = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (options_done || a.size() < 2 || a[0] != '-' || looks_numeric(a)) {
      positional.push_back(a);
      continue;
    }
    if (a == "--") {
      options_done = true;
      continue;
    }
    Option* o = nullptr;
    std::string value;
    bool inline_value = false;
    std::string shown;
    if (a.compare(0, 2, "--") == 0) {
      std::string name = a.substr(2);
      const std::size_t eq = name.find('=');
      if (eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        inline_value = true;
      }
      o = find_long(name);
      shown = "--" + name;
      if (!o) throw UsageError("unknown option " + shown + suggest(name));
    } else {
      if (a.size() != 2) throw UsageError("unknown option " + a + " (short options stand alone)");
      o = find_short(a[1]);
      shown = a;
      if (!o) throw UsageError("unknown option " + a);
    }
    if (o->was_seen && !o->repeatable) throw UsageError("option " + shown + " given twice");
    o->was_seen = true;
    if (!o->takes_value) {
      if (inline_value) throw UsageError("option " + shown + " takes no value");
      o->set("");
      continue;
    }
    if (!inline_value) {
      if (i + 1 >= args.size())
        throw UsageError("option " + shown + " needs a value " + o->metavar);
      value = args[++i];
    }
    o->set(value);
  }
  for (const Option& o : options_)
    if (o.is_required && !o.was_seen)
      throw UsageError("missing required option --" + o.name + " " + o.metavar);
  if (positional.size() < positionals_.size()) {
    throw UsageError("missing argument " + positionals_[positional.size()].name);
  }
  for (std::size_t i = 0; i < positionals_.size(); ++i) *positionals_[i].out = positional[i];
  const std::size_t extra = positional.size() - positionals_.size();
  if (rest_) {
    if (extra < rest_min_) throw UsageError("missing argument " + rest_name_);
    rest_->assign(positional.begin() + static_cast<std::ptrdiff_t>(positionals_.size()),
                  positional.end());
  } else if (extra > 0) {
    throw UsageError("unexpected argument '" + positional[positionals_.size()] + "'");
  }
  return true;
}

std::string ArgParser::help() const {
  std::ostringstream s;
  s << "usage: " << program_ << ' ' << synopsis_ << "\n\n" << description_ << '\n';
  auto row = [&s](const std::string& left, const std::string& text) {
    constexpr std::size_t kColumn = 28;
    s << "  " << left;
    if (left.size() + 2 >= kColumn) {
      s << '\n' << std::string(kColumn, ' ');
    } else {
      s << std::string(kColumn - 2 - left.size(), ' ');
    }
    // Continuation lines of a multi-line help text line up under its first line.
    for (const char c : text) {
      s << c;
      if (c == '\n') s << std::string(kColumn, ' ');
    }
    s << '\n';
  };
  if (!positionals_.empty() || rest_) {
    s << "\narguments:\n";
    for (const Positional& p : positionals_) row(p.name, p.help);
    if (rest_) row(rest_name_, rest_help_);
  }
  s << "\noptions:\n";
  for (const Option& o : options_) {
    std::string left = o.short_name ? std::string("-") + o.short_name + ", " : "";
    left += "--" + o.name;
    if (o.takes_value) left += " " + o.metavar;
    std::string text = o.help;
    if (o.is_required) text += " (required)";
    if (!o.default_text.empty()) text += " (default: " + o.default_text + ")";
    row(left, text);
  }
  row("-h, --help", "show this help and exit");
  if (!epilog_.empty()) s << '\n' << epilog_ << (epilog_.back() == '\n' ? "" : "\n");
  return s.str();
}

}  // namespace cadinterp::cli
