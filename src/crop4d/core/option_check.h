#pragma once

// The one rule for option checks (DESIGN.md §7): an option struct's `Check()` returns which
// option is wrong and why, "<option>: <why>" (e.g. "cell_m: must be > 0 (got -1)"), or nothing
// when all are valid; a nested struct's reason is passed up with its key as a prefix
// ("stereo.cell_m: ..."). Callers that take options from a user throw it as an InputError;
// algorithms that get options from code CHECK it (a programmer error).

#include <fmt/format.h>

#include <cmath>
#include <string>
#include <utility>

#include "crop4d/core/error.h"

namespace crop4d {

// What Check() returns: empty when the options are valid, else the reason.
class OptionCheck : public std::string {
 public:
  OptionCheck() = default;
  OptionCheck(const char* reason) : std::string(reason) {}             // NOLINT: implicit by design
  OptionCheck(std::string reason) : std::string(std::move(reason)) {}  // NOLINT
};

// Builds a Check() result: each test records the first failure and the later ones are skipped.
//   OptionChecker c;
//   c.Greater("cell_m", cell_m, 0.0).InRange("patch_radius", patch_radius, 1, 5);
//   c.Nested("triangulation", triangulation.Check());
//   return c.Result();
// A comparison fails for NaN (it holds only when the value compares true).
class OptionChecker {
 public:
  template <class T, class B>
  OptionChecker& Greater(const char* key, const T& value, const B& bound) {
    if (ok() && !(value > bound)) Fail(key, fmt::format("must be > {}", bound), value);
    return *this;
  }
  template <class T, class B>
  OptionChecker& AtLeast(const char* key, const T& value, const B& bound) {
    if (ok() && !(value >= bound)) Fail(key, fmt::format("must be >= {}", bound), value);
    return *this;
  }
  template <class T, class B>
  OptionChecker& Less(const char* key, const T& value, const B& bound) {
    if (ok() && !(value < bound)) Fail(key, fmt::format("must be < {}", bound), value);
    return *this;
  }
  template <class T, class B>
  OptionChecker& AtMost(const char* key, const T& value, const B& bound) {
    if (ok() && !(value <= bound)) Fail(key, fmt::format("must be <= {}", bound), value);
    return *this;
  }
  // lo <= value <= hi.
  template <class T, class B>
  OptionChecker& InRange(const char* key, const T& value, const B& lo, const B& hi) {
    if (ok() && !(value >= lo && value <= hi)) {
      Fail(key, fmt::format("must be in [{}, {}]", lo, hi), value);
    }
    return *this;
  }
  // lo < value < hi.
  template <class T, class B>
  OptionChecker& Between(const char* key, const T& value, const B& lo, const B& hi) {
    if (ok() && !(value > lo && value < hi)) {
      Fail(key, fmt::format("must be in ({}, {})", lo, hi), value);
    }
    return *this;
  }
  template <class T>
  OptionChecker& Finite(const char* key, const T& value) {
    if (ok() && !std::isfinite(value)) Fail(key, "must be finite", value);
    return *this;
  }
  // Any other rule: `why` says what must hold, e.g. "must be < fine_half_range_m"; the
  // value, when given, is appended as "(got <value>)".
  OptionChecker& Require(bool holds, const char* key, const std::string& why) {
    if (ok() && !holds) reason_ = std::string(key) + ": " + why;
    return *this;
  }
  template <class T>
  OptionChecker& Require(bool holds, const char* key, const std::string& why, const T& value) {
    if (ok() && !holds) Fail(key, why, value);
    return *this;
  }
  // A nested struct's Check(), passed up as "<key>.<its reason>".
  OptionChecker& Nested(const char* key, const OptionCheck& nested) {
    if (ok() && !nested.empty()) reason_ = std::string(key) + "." + nested;
    return *this;
  }

  bool ok() const { return reason_.empty(); }
  OptionCheck Result() const { return reason_; }

 private:
  template <class T>
  void Fail(const char* key, const std::string& why, const T& value) {
    reason_ = fmt::format("{}: {} (got {})", key, why, value);
  }

  std::string reason_;
};

}  // namespace crop4d

// Aborts with "<what>: <reason>" when `options` (an option struct given by code, not by a user)
// is invalid: a programmer error (DESIGN.md §7).
#define CROP4D_CHECK_OPTIONS(options, what)                               \
  do {                                                                    \
    const ::crop4d::OptionCheck crop4d_option_check_ = (options).Check(); \
    CROP4D_CHECK_MSG(crop4d_option_check_.empty(),                        \
                     std::string(what) + ": " + crop4d_option_check_);    \
  } while (0)
