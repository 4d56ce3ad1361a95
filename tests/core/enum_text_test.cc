// Enums as text (core/enum_text.h): every name round-trips, other text is
// refused naming the choices, and a value outside the table prints as "?".
#include <gtest/gtest.h>

#include "core/btf.h"
#include "core/enum_text.h"
#include "core/error.h"
#include "core/image_io.h"

namespace mesocap::core {
namespace {

TEST(EnumText, EveryNameRoundTripsInTheEnumeratorsOrder) {
  EXPECT_EQ(EnumStrings<BtfFactorLayout>(), (std::vector<std::string>{"paper", "per_texel", "clustered", "per_view"}));
  for (const std::string& name : EnumStrings<BtfFactorLayout>()) {
    const std::optional<BtfFactorLayout> layout = EnumFromString<BtfFactorLayout>(name);
    ASSERT_TRUE(layout.has_value()) << name;
    EXPECT_EQ(ToString(*layout), name);
  }
  EXPECT_STREQ(ToString(BtfFactorLayout::kPerView), "per_view");
  EXPECT_STREQ(ToString(PixelEncoding::kUInt16), "uint16");
  EXPECT_EQ(EnumFromString<BtfFactorColor>("ycbcr"), BtfFactorColor::kYCbCr);
}

TEST(EnumText, OtherTextIsRefusedNamingTheChoices) {
  EXPECT_FALSE(EnumFromString<BtfFactorLayout>("Paper").has_value());
  EXPECT_FALSE(EnumFromString<BtfFactorLayout>("").has_value());
  try {
    ParseEnum<BtfFactorLayout>("tiled", "layout");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "unknown layout \"tiled\" (expected paper, per_texel, clustered or per_view)");
  }
  EXPECT_EQ(ParseEnum<BtfFactorColor>("rgb", "colour"), BtfFactorColor::kRgb);
}

TEST(EnumText, AValueOutsideTheTablePrintsAsAQuestionMark) {
  EXPECT_STREQ(ToString(static_cast<BtfFactorLayout>(7)), "?");
}

TEST(OptionsCheck, ThrowIfInvalidNamesWhoWasGivenTheOptions) {
  EXPECT_NO_THROW(ThrowIfInvalid("", "process mdf"));
  try {
    ThrowIfInvalid("--texture-size: expected 1..4096", "process mdf");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "process mdf: --texture-size: expected 1..4096");
  }
}

}  // namespace
}  // namespace mesocap::core
