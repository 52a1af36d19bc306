// The expression language (expression.h): terms and weights parsed from text, and errors that
// name the offending token and its column.
#include <gtest/gtest.h>

#include <string>

#include "cadinterp/cadinterp_optimize.h"
#include "optimize/expression.h"
#include "optimize/test_assets.h"

namespace {

using cadinterp::optimize::parse_constraint;
using cadinterp::optimize::parse_expression;

const cadinterp_asset* test_asset() {
  std::string error;
  const auto* a = cadinterp::optimize::test::box_asset(2, 1, {0.5, 0.5, 0, 0, 0}, false, &error);
  EXPECT_TRUE(a) << error;
  return a ? a->asset : nullptr;
}

TEST(Expression, ParsesTermsAndWeights) {
  const cadinterp_asset* a = test_asset();
  ASSERT_TRUE(a);
  auto p = parse_expression(a, "integral(q) + 0.1*mass(7.8) - 2e-1 * region_integral(s, top)");
  ASSERT_EQ(p.status, CADINTERP_OK) << p.error;
  ASSERT_EQ(p.terms.size(), 3u);
  EXPECT_EQ(p.terms[0].quantity, CADINTERP_OPTIMIZE_INTEGRAL);
  EXPECT_EQ(p.terms[0].field, 0);
  EXPECT_EQ(p.terms[0].region, -1);
  EXPECT_EQ(p.terms[1].quantity, CADINTERP_OPTIMIZE_MASS);
  EXPECT_DOUBLE_EQ(p.terms[1].weight, 0.1);
  EXPECT_DOUBLE_EQ(p.terms[1].parameter, 7.8);
  EXPECT_EQ(p.terms[2].field, 1);
  EXPECT_EQ(p.terms[2].region, 1);
  EXPECT_DOUBLE_EQ(p.terms[2].weight, -0.2);
  p = parse_expression(a,
                       "max(q, p=12) + max('s', ks=5) + inertia_xz + centroid_y + "
                       "frontal_area(1, 0, 0) + region_area(bottom) + area + volume");
  ASSERT_EQ(p.status, CADINTERP_OK) << p.error;
  ASSERT_EQ(p.terms.size(), 8u);
  EXPECT_EQ(p.terms[0].quantity, CADINTERP_OPTIMIZE_MAX_PNORM);
  EXPECT_DOUBLE_EQ(p.terms[0].parameter, 12);
  EXPECT_EQ(p.terms[1].quantity, CADINTERP_OPTIMIZE_MAX_KS);
  EXPECT_EQ(p.terms[2].component, 2);
  EXPECT_EQ(p.terms[3].component, 1);
  EXPECT_DOUBLE_EQ(p.terms[4].direction[0], 1.0);
  EXPECT_EQ(p.terms[5].field, -1);
  EXPECT_EQ(p.terms[5].region, 0);
  // Outputs: output(NAME) or the bare name; a quantity's name is never an output.
  p = parse_expression(a, "output(brep_volume) - 2*exact_integral_q + volume");
  ASSERT_EQ(p.status, CADINTERP_OK) << p.error;
  ASSERT_EQ(p.terms.size(), 3u);
  EXPECT_EQ(p.terms[0].quantity, CADINTERP_OPTIMIZE_OUTPUT);
  EXPECT_EQ(p.terms[0].field, 0);
  EXPECT_EQ(p.terms[1].quantity, CADINTERP_OPTIMIZE_OUTPUT);
  EXPECT_EQ(p.terms[1].field, 1);
  EXPECT_DOUBLE_EQ(p.terms[1].weight, -2);
  EXPECT_EQ(p.terms[2].quantity, CADINTERP_OPTIMIZE_VOLUME);
  const auto c = parse_constraint(a, "volume <= 1.2e4");
  ASSERT_EQ(c.status, CADINTERP_OK) << c.error;
  EXPECT_EQ(c.upper, 1.2e4);
  EXPECT_TRUE(std::isinf(c.lower));
  const auto e = parse_constraint(a, "area == -3");
  EXPECT_EQ(e.lower, -3);
  EXPECT_EQ(e.upper, -3);
}

// Each error names the token and its 1-based column.
TEST(Expression, ErrorsNameTheTokenAndColumn) {
  const cadinterp_asset* a = test_asset();
  ASSERT_TRUE(a);
  struct Bad {
    const char* text;
    bool constraint;
    cadinterp_status status;
    const char* message;
  } cases[] = {
      {"integral(q) + mas", false, CADINTERP_E_INVALID_ARGUMENT,
       "column 15: unknown quantity 'mas'"},
      {"integral(stress)", false, CADINTERP_E_NOT_FOUND,
       "column 10: the asset has no field 'stress'"},
      {"region_integral(q, load)", false, CADINTERP_E_NOT_FOUND,
       "column 20: the asset has no region 'load'"},
      {"integral(q", false, CADINTERP_E_INVALID_ARGUMENT,
       "column 11: expected ')', got end of expression"},
      {"2 mass", false, CADINTERP_E_INVALID_ARGUMENT,
       "column 3: expected '*' after a weight, got 'mass'"},
      {"max(q, p=0.5)", false, CADINTERP_E_INVALID_ARGUMENT,
       "column 10: p must be >= 1, got '0.5'"},
      {"volume # 2", false, CADINTERP_E_INVALID_ARGUMENT, "column 8: unexpected character '#'"},
      {"", false, CADINTERP_E_INVALID_ARGUMENT, "column 1: empty expression: end of expression"},
      {"integral(q, 1)", false, CADINTERP_E_INVALID_ARGUMENT,
       "component 1 of field 'q', which has 1"},
      {"volume", true, CADINTERP_E_INVALID_ARGUMENT,
       "column 7: expected '<=', '>=' or '==', got end of expression"},
      {"volume < 3", true, CADINTERP_E_INVALID_ARGUMENT, "column 8: unexpected character '<'"},
      {"volume <= mass", true, CADINTERP_E_INVALID_ARGUMENT,
       "column 11: expected a number, got 'mass'"},
      {"output(volume)", false, CADINTERP_E_NOT_FOUND,
       "column 8: the asset has no output 'volume'"},
      {"output(brep_volume", false, CADINTERP_E_INVALID_ARGUMENT,
       "column 19: expected ')', got end of expression"},
      {"mass volume", false, CADINTERP_E_INVALID_ARGUMENT,
       "column 6: expected '+', '-' or the end, got 'volume'"},
  };
  for (const Bad& b : cases) {
    const auto p = b.constraint ? parse_constraint(a, b.text) : parse_expression(a, b.text);
    EXPECT_EQ(p.status, b.status) << b.text;
    EXPECT_NE(p.error.find(b.message), std::string::npos) << b.text << " -> " << p.error;
    EXPECT_TRUE(p.terms.empty());
  }
  // Through the C ABI: nothing is added on failure, the message is the parser's.
  cadinterp_optimize_problem* p = nullptr;
  ASSERT_EQ(cadinterp_optimize_create(a, &p), CADINTERP_OK);
  EXPECT_EQ(cadinterp_optimize_parse(p, 0, "volume + bogus"), CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_STREQ(cadinterp_optimize_error(p), "column 10: unknown quantity 'bogus'");
  EXPECT_EQ(cadinterp_optimize_parse_constraint(p, "volume <=", nullptr),
            CADINTERP_E_INVALID_ARGUMENT);
  EXPECT_EQ(cadinterp_optimize_constraint_count(p), 0);
  cadinterp_optimize_destroy(p);
}

}  // namespace
