#include "posekit/core/units.h"

#include <gtest/gtest.h>

#include "posekit/core/error.h"

using namespace posekit;

TEST(Units, ParseAndNameRoundTrip) {
  for (Unit u : {Unit::kMetre, Unit::kDecimetre, Unit::kCentimetre, Unit::kMillimetre})
    EXPECT_EQ(parse_unit(unit_name(u)), u);
  EXPECT_EQ(parse_unit("Millimetres"), Unit::kMillimetre);
  EXPECT_DOUBLE_EQ(metres_per_unit(Unit::kCentimetre), 0.01);
  EXPECT_THROW(parse_unit("inch"), InvalidInput);
}

TEST(Units, GuessesTheUnitOfAStandingBody) {
  Unit u;
  ASSERT_TRUE(guess_body_unit(1.75, &u));
  EXPECT_EQ(u, Unit::kMetre);
  ASSERT_TRUE(guess_body_unit(17.3, &u));
  EXPECT_EQ(u, Unit::kDecimetre);
  ASSERT_TRUE(guess_body_unit(172.0, &u));
  EXPECT_EQ(u, Unit::kCentimetre);
  ASSERT_TRUE(guess_body_unit(1700.0, &u));
  EXPECT_EQ(u, Unit::kMillimetre);
  EXPECT_FALSE(guess_body_unit(1e7, &u));
}
