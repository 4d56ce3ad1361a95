// How an enum is written as text, in files, flags and messages, and read
// back. Each such enum has one table of names, in the enumerators' order
// (which run 0, 1, 2, ...), a function EnumNamesOf beside its declaration
// (found by argument-dependent lookup), and only these functions read it:
//
//   enum class RenderMode { kBtf, kSilhouette, kFull };
//   constexpr auto EnumNamesOf(RenderMode) { return std::to_array({"btf", "silhouette", "full"}); }
//
// A header declaring such an enum outside core says `using core::ToString;`
// in its namespace, so that ToString(value) is found there as for core's.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"

namespace mesocap::core {

// The value's name in its table ("?" for a value outside it: a cast integer).
template <typename Enum, typename = decltype(EnumNamesOf(Enum{}))>
const char* ToString(Enum value) {
  const auto names = EnumNamesOf(Enum{});
  const auto index = static_cast<std::size_t>(value);
  return index < names.size() ? names[index] : "?";
}

// The value named `text`; std::nullopt for any other text.
template <typename Enum>
std::optional<Enum> EnumFromString(std::string_view text) {
  const auto names = EnumNamesOf(Enum{});
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (text == names[i]) return static_cast<Enum>(i);
  }
  return std::nullopt;
}

// Every name, in the table's order: for a flag's or a file field's choices.
template <typename Enum>
std::vector<std::string> EnumStrings() {
  std::vector<std::string> names;
  for (const char* name : EnumNamesOf(Enum{})) names.emplace_back(name);
  return names;
}

// The value named `text`, or Error("unknown WHAT "TEXT" (expected a, b or c)").
template <typename Enum>
Enum ParseEnum(std::string_view text, std::string_view what) {
  if (const std::optional<Enum> value = EnumFromString<Enum>(text)) return *value;
  const std::vector<std::string> names = EnumStrings<Enum>();
  std::string expected;
  for (std::size_t i = 0; i < names.size(); ++i) {
    expected += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  }
  throw Error("unknown " + std::string(what) + " " + Quoted(text) + " (expected " + expected + ")");
}

}  // namespace mesocap::core
