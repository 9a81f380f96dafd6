// The ranking of a round's re-fits (screening.h, "Ranking"; internal::RankRefits of the private
// diagnosis/src/screening_internal.h, on this test's include path): groups, validation NRMSE, ties
// settled by BIC in runs measured from their best, and parsimony between nested effects: the
// simpler one takes the general one's place.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "screening_internal.h"

namespace graybox::diagnosis::internal {
namespace {

// ScreeningOptions' defaults: ties within 1e-3 relative; the nested margin 0.02 x a nominal
// validation NRMSE of 0.281 (the DC motor's second round).
constexpr double kTie = 1e-3;
constexpr double kMargin = 0.02 * 0.281;

RefitResult Refit(const std::string& effect, double nrmse, double bic, bool ok = true,
                  bool at_bound = false, std::vector<std::string> reduces_to = {}) {
  RefitResult r;
  r.effect = effect;
  r.attachment = "velocity shaft.qd -> force torque";
  r.validation_nrmse_after = nrmse;
  r.bic = bic;
  r.ok = ok;
  r.at_bound = at_bound;
  r.candidate.effect = effect;
  r.candidate.reduces_to = std::move(reduces_to);
  return r;
}

std::vector<std::string> Order(std::vector<RefitResult> refits) {
  RankRefits(kTie, kMargin, &refits);
  std::vector<std::string> names;
  for (const RefitResult& r : refits) names.push_back(r.effect);
  return names;
}

TEST(RankRefits, OkInteriorThenAtABoundThenFailedWhateverTheirErrors) {
  EXPECT_EQ(Order({Refit("failed", 0.1, -900.0, false), Refit("bound", 0.2, -800.0, true, true),
                   Refit("worse", 0.4, -100.0), Refit("better", 0.3, -200.0)}),
            (std::vector<std::string>{"better", "worse", "bound", "failed"}));
}

// a, b and c are 0.0008 apart: b ties with a and c with b, but c does not tie with a (0.0016
// apart). The run from a holds a and b, ordered by BIC; c follows, although its BIC is the lowest.
TEST(RankRefits, TiesAreRunsWithinTheToleranceOfTheirBest) {
  EXPECT_EQ(Order({Refit("c", 1.0016, -30.0), Refit("a", 1.0, -10.0), Refit("b", 1.0008, -20.0)}),
            (std::vector<std::string>{"b", "a", "c"}));
  // The same in any input order.
  EXPECT_EQ(Order({Refit("b", 1.0008, -20.0), Refit("c", 1.0016, -30.0), Refit("a", 1.0, -10.0)}),
            (std::vector<std::string>{"b", "a", "c"}));
}

// The DC motor's second round at 2430167: the two-level asymmetric friction, which contains the
// constant offset (the same effect name, another variant), is best, and better than the offset by
// less than the margin: the offset takes its place and it follows; the Dahl and Coulomb re-fits,
// tied with the offset and ahead of it by BIC, stay behind the family.
TEST(RankRefits, TheSimplerEffectTakesTheGeneralOnesPlace) {
  std::vector<RefitResult> refits = {
      Refit("asymmetric_friction", 0.2741, -62917.3), Refit("coulomb", 0.2741, -62920.6),
      Refit("presliding", 0.2739, -62932.5),
      Refit("asymmetric_friction", 0.2727, -63296.5, true, false, {"asymmetric_friction"}),
      Refit("stribeck", 0.2103, -74425.7, true, true, {"coulomb"})};
  refits[0].detail = "friction.offset";
  refits[3].detail = "friction.asymmetric";
  RankRefits(kTie, kMargin, &refits);
  std::vector<std::string> order;
  for (const RefitResult& r : refits) order.push_back(r.effect + " " + r.detail);
  EXPECT_EQ(order, (std::vector<std::string>{"asymmetric_friction friction.offset",
                                             "asymmetric_friction friction.asymmetric",
                                             "presliding ", "coulomb ", "stribeck "}));
}

// EMPS without its asymmetry, round 2: the family's best (0.03604) beats an output offset
// (0.03647) by more than a tie, its simpler member (0.03658) does not; the family ranks by its
// best.
TEST(RankRefits, ANestedFamilyRanksByItsBestMember) {
  EXPECT_EQ(Order({Refit("sensor_offset", 0.03647, -323836.1), Refit("offset", 0.03658, -323318.7),
                   Refit("asymmetric", 0.03604, -325323.4, true, false, {"offset"})}),
            (std::vector<std::string>{"offset", "asymmetric", "sensor_offset"}));
}

// Better than its simpler effect by more than the margin: the general effect keeps its place.
TEST(RankRefits, AGeneralEffectBetterByMoreThanTheMarginStaysFirst) {
  EXPECT_EQ(Order({Refit("coulomb", 0.30, -100.0),
                   Refit("stribeck", 0.20, -200.0, true, false, {"coulomb"})}),
            (std::vector<std::string>{"stribeck", "coulomb"}));
}

// Two nested steps: a LuGre re-fit contains presliding; a Stribeck curve contains Coulomb
// friction. Each simpler one takes its general one's place.
TEST(RankRefits, EveryGeneralEffectWithinTheMarginGivesWayToItsSimplerOne) {
  EXPECT_EQ(Order({Refit("lugre", 0.100, -10.0, true, false, {"presliding"}),
                   Refit("stribeck", 0.101, -20.0, true, false, {"coulomb"}),
                   Refit("presliding", 0.102, -5.0), Refit("coulomb", 0.103, -6.0)}),
            (std::vector<std::string>{"presliding", "lugre", "coulomb", "stribeck"}));
}

// A simpler one that contains a simpler one still: the position is checked again after a move.
TEST(RankRefits, ASimplerEffectThatMovedUpIsCheckedAgain) {
  EXPECT_EQ(Order({Refit("a", 0.100, -10.0, true, false, {"b"}),
                   Refit("b", 0.101, -20.0, true, false, {"c"}), Refit("c", 0.102, -5.0)}),
            (std::vector<std::string>{"c", "b", "a"}));
}

// A simpler effect on another attachment does not count.
TEST(RankRefits, ParsimonyOnlyOnTheSameAttachment) {
  std::vector<RefitResult> refits = {Refit("stribeck", 0.100, -20.0, true, false, {"coulomb"}),
                                     Refit("coulomb", 0.101, -10.0)};
  refits[1].attachment = "velocity other.qd -> force other";
  RankRefits(kTie, kMargin, &refits);
  EXPECT_EQ(refits.front().effect, "stribeck");
}

}  // namespace
}  // namespace graybox::diagnosis::internal
