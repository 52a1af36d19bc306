// Command-line parsing for the `cadinterp` tool: typed options bound to variables, checked
// ranges, and a --help text generated from the same declarations, so the help never disagrees
// with what is accepted.
//
//   ArgParser p("cadinterp eval", "ASSET X1 X2 ...", "Evaluates ...");
//   p.option("fields", 0, "A,B", "fields to evaluate", &fields);
//   p.option("iterations", 'n', "N", "how many", &n, 1, 1000000);
//   p.positional("ASSET", "the asset file", &asset);
//   if (!p.parse(args)) return 0;  // --help was printed
//
// Syntax: --name VALUE, --name=VALUE, -n VALUE; "--" ends the options. A token that starts
// with '-' but reads as a number ("-0.5") is a positional, since parameter values can be
// negative. Errors throw UsageError (the tool exits with 2).
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace cadinterp::cli {

/// A malformed command line; what() is the message for the user.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Whole-token, finite number parsing (no trailing characters, no "nan", no "inf").
bool parse_double(const std::string& s, double* out);
bool parse_int(const std::string& s, long long* out);
/// Splits "a,b,c" at commas ("" gives no items).
std::vector<std::string> split_list(const std::string& s, char sep = ',');

class ArgParser {
 public:
  /// `program`: e.g. "cadinterp eval"; `synopsis`: what follows it in the usage line.
  ArgParser(std::string program, std::string synopsis, std::string description);

  ArgParser& flag(const std::string& name, char short_name, const std::string& help, bool* out);
  ArgParser& option(const std::string& name, char short_name, const std::string& metavar,
                    const std::string& help, std::string* out);
  ArgParser& option(const std::string& name, char short_name, const std::string& metavar,
                    const std::string& help, int* out, int min, int max);
  ArgParser& option(const std::string& name, char short_name, const std::string& metavar,
                    const std::string& help, double* out, double min, double max);
  /// A string option that may be given several times: each value is appended to `out`.
  ArgParser& repeated(const std::string& name, char short_name, const std::string& metavar,
                      const std::string& help, std::vector<std::string>* out);
  /// One of `choices` (exact match).
  ArgParser& choice(const std::string& name, char short_name, const std::string& help,
                    const std::vector<std::string>& choices, std::string* out);
  /// Makes the option declared last required.
  ArgParser& required();
  /// Shows the current value of the option declared last as its default in the help (options
  /// bound to a string show it automatically when non-empty).
  ArgParser& show_default(const std::string& text);

  /// A required positional argument, in declaration order.
  ArgParser& positional(const std::string& name, const std::string& help, std::string* out);
  /// Every remaining positional (after the declared ones); at least `min_count`.
  ArgParser& rest(const std::string& name, const std::string& help, std::vector<std::string>* out,
                  std::size_t min_count);
  /// Free text appended to the help (examples, notes).
  ArgParser& epilog(const std::string& text);

  /// Parses `args` (without the program and command names). Returns false when --help was
  /// given (the help is printed to stdout and nothing else is checked). Throws UsageError.
  bool parse(const std::vector<std::string>& args);
  /// Whether the option `name` appeared on the command line.
  bool seen(const std::string& name) const;
  std::string help() const;
  const std::string& program() const { return program_; }

 private:
  struct Option {
    std::string name, metavar, help, default_text;
    char short_name = 0;
    bool takes_value = true;
    bool is_required = false;
    bool was_seen = false;
    bool repeatable = false;
    std::function<void(const std::string&)> set;  // throws UsageError with the reason
  };
  struct Positional {
    std::string name, help;
    std::string* out = nullptr;
  };
  Option& add(const std::string& name, char short_name, const std::string& metavar,
              const std::string& help);
  Option* find_long(const std::string& name);
  Option* find_short(char c);
  std::string suggest(const std::string& name) const;

  std::string program_, synopsis_, description_, epilog_;
  std::vector<Option> options_;
  std::vector<Positional> positionals_;
  std::string rest_name_, rest_help_;
  std::vector<std::string>* rest_ = nullptr;
  std::size_t rest_min_ = 0;
};

}  // namespace cadinterp::cli
