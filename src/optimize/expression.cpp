// Tokenizer and recursive-descent parser of the optimization expression language. Every error
// names the offending token and its 1-based column, so that a command line typo is found at once.
#include "optimize/expression.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace cadinterp::optimize {
namespace {

struct Token {
  enum Kind { Number, Name, Punct, End } kind;
  std::string text;
  double number = 0;
  int column = 0;  // 1-based
};

struct ParseError {
  cadinterp_status status;
  std::string message;
};

[[noreturn]] void error_at(const Token& t, const std::string& what,
                           cadinterp_status s = CADINTERP_E_INVALID_ARGUMENT) {
  const std::string tok = t.kind == Token::End ? "end of expression" : "'" + t.text + "'";
  throw ParseError{s, "column " + std::to_string(t.column) + ": " + what + " " + tok};
}

bool name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

std::vector<Token> tokenize(const char* text) {
  std::vector<Token> out;
  const std::size_t n = std::strlen(text);
  std::size_t i = 0;
  while (i < n) {
    const char c = text[i];
    const int col = static_cast<int>(i) + 1;
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      char* end = nullptr;
      const double v = std::strtod(text + i, &end);
      const std::size_t len = static_cast<std::size_t>(end - (text + i));
      if (len == 0) error_at({Token::Punct, std::string(1, c), 0, col}, "malformed number");
      out.push_back({Token::Number, std::string(text + i, len), v, col});
      i += len;
    } else if (name_char(c)) {
      std::size_t j = i;
      while (j < n && name_char(text[j])) ++j;
      out.push_back({Token::Name, std::string(text + i, j - i), 0, col});
      i = j;
    } else if (c == '\'') {
      const char* close = std::strchr(text + i + 1, '\'');
      if (!close) error_at({Token::Punct, "'", 0, col}, "unterminated quoted name at");
      out.push_back({Token::Name, std::string(text + i + 1, close), 0, col});
      i = static_cast<std::size_t>(close - text) + 1;
    } else if ((c == '<' || c == '>' || c == '=') && i + 1 < n && text[i + 1] == '=') {
      out.push_back({Token::Punct, std::string(text + i, 2), 0, col});
      i += 2;
    } else if (std::strchr("+-*(),=", c)) {
      out.push_back({Token::Punct, std::string(1, c), 0, col});
      ++i;
    } else {
      error_at({Token::Punct, std::string(1, c), 0, col}, "unexpected character");
    }
  }
  out.push_back({Token::End, "", 0, static_cast<int>(n) + 1});
  return out;
}

class Parser {
 public:
  Parser(const cadinterp_asset* asset, std::vector<Token> tokens)
      : asset_(asset), t_(std::move(tokens)) {}

  // sum := ['+'|'-'] term (('+'|'-') term)*, up to a comparison or the end.
  std::vector<cadinterp_optimize_term> sum() {
    std::vector<cadinterp_optimize_term> out;
    double sign = 1.0;
    if (is("+") || is("-")) sign = next().text == "-" ? -1.0 : 1.0;
    for (;;) {
      out.push_back(term(sign));
      if (!is("+") && !is("-")) break;
      sign = next().text == "-" ? -1.0 : 1.0;
    }
    return out;
  }
  const Token& peek() const { return t_[pos_]; }
  const Token& next() { return t_[pos_ == t_.size() - 1 ? pos_ : pos_++]; }
  bool is(const char* punct) const { return peek().kind == Token::Punct && peek().text == punct; }
  double number(const char* what) {
    double sign = 1.0;
    if (is("-") || is("+")) sign = next().text == "-" ? -1.0 : 1.0;
    if (peek().kind != Token::Number) error_at(peek(), std::string("expected ") + what + ", got");
    return sign * next().number;
  }

 private:
  void expect(const char* punct) {
    if (!is(punct)) error_at(peek(), std::string("expected '") + punct + "', got");
    next();
  }

  // term := [NUMBER '*'] quantity
  cadinterp_optimize_term term(double sign) {
    double weight = sign;
    if (peek().kind == Token::Number) {
      weight *= next().number;
      if (!is("*")) error_at(peek(), "expected '*' after a weight, got");
      next();
    }
    cadinterp_optimize_term q = quantity();
    q.weight = weight;
    return q;
  }

  int field_index(const Token& t) {
    int index = -1;
    if (t.kind != Token::Name) error_at(t, "expected a field name, got");
    if (cadinterp_find_field(asset_, t.text.c_str(), &index) != CADINTERP_OK)
      error_at(t, "the asset has no field", CADINTERP_E_NOT_FOUND);
    return index;
  }
  int region_index(const Token& t) {
    if (t.kind != Token::Name) error_at(t, "expected a region name, got");
    for (int r = 0; r < cadinterp_region_count(asset_); ++r) {
      cadinterp_region_info info;
      if (cadinterp_region(asset_, r, &info) == CADINTERP_OK && t.text == info.name) return r;
    }
    error_at(t, "the asset has no region", CADINTERP_E_NOT_FOUND);
  }
  int component() {
    const Token& t = peek();
    const double c = number("a component index");
    if (c != std::floor(c) || c < 0 || c > 64) error_at(t, "expected a component index, got");
    return static_cast<int>(c);
  }
  // The optional "(density)" of mass and inertia.
  void density(cadinterp_optimize_term& q) {
    if (!is("(")) return;
    next();
    q.parameter = number("a density");
    expect(")");
  }
  void field_max(cadinterp_optimize_term& q) {
    q.quantity = CADINTERP_OPTIMIZE_MAX_PNORM;
    q.parameter = 8.0;
    q.field = field_index(next());
    while (is(",")) {
      next();
      if (peek().kind == Token::Name && (peek().text == "p" || peek().text == "ks")) {
        const Token key = next();
        expect("=");
        const Token& at = peek();
        q.parameter = number(key.text == "p" ? "p" : "rho");
        if (key.text == "ks") q.quantity = CADINTERP_OPTIMIZE_MAX_KS;
        if (key.text == "p" && !(q.parameter >= 1)) error_at(at, "p must be >= 1, got");
        if (key.text == "ks" && !(q.parameter > 0)) error_at(at, "rho must be > 0, got");
      } else {
        q.component = component();
      }
    }
  }

  int output_index(const Token& t) {
    int index = -1;
    if (t.kind != Token::Name) error_at(t, "expected an output name, got");
    if (cadinterp_find_output(asset_, t.text.c_str(), &index) != CADINTERP_OK)
      error_at(t, "the asset has no output", CADINTERP_E_NOT_FOUND);
    return index;
  }

  cadinterp_optimize_term quantity() {
    const Token name = next();
    if (name.kind != Token::Name) error_at(name, "expected a quantity, got");
    int bare_output = -1;  // a quantity's name wins over an output of the same name
    cadinterp_optimize_term q;
    cadinterp_optimize_term_init(&q, CADINTERP_OPTIMIZE_VOLUME);
    const std::string& s = name.text;
    static const char* kAxes = "xyz";
    if (s == "volume") {
    } else if (s == "area") {
      q.quantity = CADINTERP_OPTIMIZE_AREA;
    } else if (s == "mass") {
      q.quantity = CADINTERP_OPTIMIZE_MASS;
      density(q);
    } else if (s == "frontal_area") {
      q.quantity = CADINTERP_OPTIMIZE_FRONTAL_AREA;
      if (is("(")) {
        next();
        for (int c = 0; c < 3; ++c) {
          if (c) expect(",");
          q.direction[c] = number("a direction component");
        }
        expect(")");
      }
    } else if (s.size() == 10 && s.compare(0, 9, "centroid_") == 0 && std::strchr(kAxes, s[9])) {
      q.quantity = CADINTERP_OPTIMIZE_CENTROID;
      q.component = static_cast<int>(std::strchr(kAxes, s[9]) - kAxes);
    } else if (s.size() == 10 && s.compare(0, 8, "inertia_") == 0 && std::strchr(kAxes, s[8]) &&
               std::strchr(kAxes, s[9])) {
      q.quantity = CADINTERP_OPTIMIZE_INERTIA;
      q.component = static_cast<int>(3 * (std::strchr(kAxes, s[8]) - kAxes) +
                                     (std::strchr(kAxes, s[9]) - kAxes));
      density(q);
    } else if (s == "integral" || s == "region_integral" || s == "region_area" || s == "max") {
      expect("(");
      q.quantity = CADINTERP_OPTIMIZE_INTEGRAL;
      if (s == "max") {
        field_max(q);
      } else {
        if (s != "region_area") q.field = field_index(next());
        if (s == "region_integral") expect(",");
        if (s != "integral") q.region = region_index(next());
        if (s != "region_area" && is(",")) {
          next();
          q.component = component();
        }
      }
      expect(")");
    } else if (s == "output") {
      expect("(");
      q.quantity = CADINTERP_OPTIMIZE_OUTPUT;
      q.field = output_index(next());
      expect(")");
    } else if (cadinterp_find_output(asset_, s.c_str(), &bare_output) == CADINTERP_OK) {
      q.quantity = CADINTERP_OPTIMIZE_OUTPUT;
      q.field = bare_output;
    } else {
      error_at(name, "unknown quantity");
    }
    return q;
  }

  const cadinterp_asset* asset_;
  std::vector<Token> t_;
  std::size_t pos_ = 0;
};

// Checks each parsed field component against the asset (the parser knows only the syntax).
void check_components(const cadinterp_asset* asset, const std::vector<Token>& tokens,
                      const std::vector<cadinterp_optimize_term>& terms) {
  for (const cadinterp_optimize_term& q : terms) {
    if (q.field < 0 || q.quantity == CADINTERP_OPTIMIZE_OUTPUT) continue;
    cadinterp_field_info f;
    cadinterp_field(asset, q.field, &f);
    if (q.component >= f.components)
      throw ParseError{CADINTERP_E_INVALID_ARGUMENT, "component " + std::to_string(q.component) +
                                                         " of field '" + f.name + "', which has " +
                                                         std::to_string(f.components) + " in '" +
                                                         tokens.front().text + "...'"};
  }
}

Parsed run(const cadinterp_asset* asset, const char* text, bool constraint) {
  Parsed out;
  try {
    std::vector<Token> tokens = tokenize(text);
    Parser p(asset, tokens);
    if (p.peek().kind == Token::End) error_at(p.peek(), "empty expression:");
    out.terms = p.sum();
    if (constraint) {
      const Token op = p.next();
      if (op.kind != Token::Punct || (op.text != "<=" && op.text != ">=" && op.text != "=="))
        error_at(op, "expected '<=', '>=' or '==', got");
      const double v = p.number("a number");
      if (op.text != ">=") out.upper = v;
      if (op.text != "<=") out.lower = v;
    }
    if (p.peek().kind != Token::End)
      error_at(p.peek(), constraint ? "unexpected token" : "expected '+', '-' or the end, got");
    check_components(asset, tokens, out.terms);
  } catch (const ParseError& e) {
    out.status = e.status;
    out.error = e.message;
    out.terms.clear();
  }
  return out;
}

}  // namespace

Parsed parse_expression(const cadinterp_asset* asset, const char* text) {
  return run(asset, text, false);
}

Parsed parse_constraint(const cadinterp_asset* asset, const char* text) {
  return run(asset, text, true);
}

}  // namespace cadinterp::optimize
