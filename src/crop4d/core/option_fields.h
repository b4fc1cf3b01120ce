#pragma once

// Option structs listed field by field, once: every option struct has a free function
//
//   template <class V> void VisitFields(Struct& options, V&& visit);
//
// next to its module (MODULE/option_fields.h), found by argument-dependent lookup, that calls
// `visit("name", options.name)` for every data member in declaration order, or
// `visit("name", options.name, fields::Role::kControl)` for a member that changes how or which
// part of a stage runs but not what it computes (threads, progress output, `force`, a session
// filter, a cache path). Everything else here is built on those lists:
//   OptionsToJson   the fields as JSON, the same way for every struct (stage fingerprints, the
//                   summaries' "options", the report);
//   VisitLeaves     every leaf field with its dotted path ("front_end.extraction.sigma"), so that
//                   the configuration file binds its keys to fields by path;
//   UnlistedFields  the check that no member was left out of a list (data members counted with
//                   C++20 aggregate initialisation: how many initialisers `T{Any{}, ...}`
//                   accepts), run by the tests of the stage options;
//   Perturb         a different value for any leaf (tests: every option changes a fingerprint).
//
// A leaf is a bool, a number, a std::string, an enum with FieldEnumNames, an Eigen vector or
// matrix of fixed size, an Eigen::AlignedBox, or a std::optional / std::vector of those or of
// listed structs. An enum type E used as a field provides, also by argument-dependent lookup,
//
//   std::span<const fields::EnumName<E>> FieldEnumNames(E);
//
// the names of all its values (written to JSON, and Perturb's next value).

#include <cmath>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace crop4d::fields {

enum class Role {
  kResult,   // changes what is computed: in the fingerprint
  kControl,  // how or which part runs (threads, progress, force, a filter): not in it
};

template <class E>
struct EnumName {
  E value;
  const char* name;
};

namespace detail {

struct NullVisitor {
  template <class T>
  void operator()(const char*, T&, Role = Role::kResult) const {}
};

}  // namespace detail

// A struct with a field list (VisitFields found by argument-dependent lookup).
template <class T>
concept Listed = std::is_class_v<T> && requires(T& t) {
  VisitFields(t, detail::NullVisitor{});
};

template <class E>
concept NamedEnum = std::is_enum_v<E> && requires(E e) {
  { FieldEnumNames(e) } -> std::convertible_to<std::span<const EnumName<E>>>;
};

// Eigen's fixed-size matrices and boxes, recognised by their members (no Eigen include here).
template <class T>
concept EigenMatrix = requires(const T& m) {
  T::RowsAtCompileTime;
  T::ColsAtCompileTime;
  m.size();
  m(0);
  T::Zero();
};
template <class T>
concept EigenBox = requires(const T& b) {
  typename T::VectorType;
  b.min();
  b.max();
  b.isEmpty();
};

template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};
template <class T>
struct IsVector : std::false_type {};
template <class T, class A>
struct IsVector<std::vector<T, A>> : std::true_type {};

// The number of data members of an aggregate: the most initialisers `T{...}` accepts from a
// value convertible to anything.
namespace detail {
struct Any {
  template <class T>
  operator T() const;
};
template <class T, class... A>
constexpr std::size_t MemberCount() {
  if constexpr (requires { T{A{}..., Any{}}; }) {
    return MemberCount<T, A..., Any>();
  } else {
    return sizeof...(A);
  }
}
}  // namespace detail
template <class T>
constexpr std::size_t MemberCount() {
  static_assert(std::is_aggregate_v<T>, "option structs are aggregates (members counted)");
  return detail::MemberCount<T>();
}

template <NamedEnum E>
const char* EnumValueName(E value) {
  for (const EnumName<E>& n : FieldEnumNames(value)) {
    if (n.value == value) return n.name;
  }
  return "?";  // a value outside the list: FieldEnumNames misses it (UnlistedFields says so)
}

// A value as JSON: numbers as numbers (written with 17 significant digits, so that any change
// of a double changes the text), non-finite numbers as "nan", "inf", "-inf", enums by name,
// listed structs as objects of their fields (kResult fields only unless `with_control`).
template <class T>
nlohmann::json ValueToJson(const T& value, bool with_control = false);

template <Listed S>
nlohmann::json OptionsToJson(const S& options, bool with_control = false) {
  S copy = options;  // VisitFields hands out mutable references
  nlohmann::json out = nlohmann::json::object();
  VisitFields(copy, [&](const char* name, auto& field, Role role = Role::kResult) {
    if (role == Role::kControl && !with_control) return;
    out[name] = ValueToJson(field, with_control);
  });
  return out;
}

template <class T>
nlohmann::json ValueToJson(const T& value, bool with_control) {
  if constexpr (Listed<T>) {
    return OptionsToJson(value, with_control);
  } else if constexpr (std::is_same_v<T, bool>) {
    return value;
  } else if constexpr (std::is_enum_v<T>) {
    static_assert(NamedEnum<T>, "an enum field needs FieldEnumNames next to its VisitFields");
    return EnumValueName(value);
  } else if constexpr (std::is_integral_v<T>) {
    return value;
  } else if constexpr (std::is_floating_point_v<T>) {
    if (std::isnan(value)) return "nan";
    if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
    return static_cast<double>(value);
  } else if constexpr (std::is_same_v<T, std::string>) {
    return value;
  } else if constexpr (IsOptional<T>::value) {
    return value ? ValueToJson(*value, with_control) : nlohmann::json(nullptr);
  } else if constexpr (IsVector<T>::value) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& item : value) out.push_back(ValueToJson(item, with_control));
    return out;
  } else if constexpr (EigenMatrix<T>) {
    nlohmann::json out = nlohmann::json::array();
    for (int i = 0; i < static_cast<int>(value.size()); ++i) out.push_back(ValueToJson(value(i)));
    return out;
  } else if constexpr (EigenBox<T>) {
    return {{"min", ValueToJson(value.min())}, {"max", ValueToJson(value.max())}};
  } else {
    static_assert(sizeof(T) == 0, "not an option leaf: list it with VisitFields or extend here");
  }
}

// Calls f(path, leaf, role) for every leaf field of `options`, depth first in declaration
// order; `path` is dotted from `options` ("optimiser.gp.qc_rotation"); a field of a kControl
// struct is kControl.
template <Listed S, class F>
void VisitLeaves(S& options, F&& f, const std::string& prefix = "", Role parent = Role::kResult) {
  VisitFields(options, [&](const char* name, auto& field, Role role = Role::kResult) {
    using T = std::remove_cvref_t<decltype(field)>;
    const std::string path = prefix.empty() ? std::string(name) : prefix + "." + name;
    const Role r = parent == Role::kControl ? Role::kControl : role;
    if constexpr (Listed<T>) {
      VisitLeaves(field, f, path, r);
    } else {
      f(path, field, r);
    }
  });
}

// The leaf at `path` if it is there and of type T, else nullptr.
template <class T, Listed S>
T* FindField(S& options, std::string_view path) {
  T* found = nullptr;
  VisitLeaves(options, [&](const std::string& p, auto& field, Role) {
    if constexpr (std::is_same_v<std::remove_cvref_t<decltype(field)>, T>) {
      if (p == path) found = &field;
    }
  });
  return found;
}

// A sample element for a vector field that is empty by default.
template <class T>
T SampleValue() {
  if constexpr (EigenMatrix<T>) {
    return T::Zero();
  } else if constexpr (EigenBox<T>) {
    using V = typename T::VectorType;
    return T(V::Zero(), V::Ones());
  } else {
    return T{};
  }
}

// Changes a leaf to another valid-looking value: bools flipped, numbers +1 (×2 where +1 is
// lost in the rounding; non-finite ones become 1), strings extended, enums to the next named
// value, optionals set or reset, vectors given one more element, Eigen values shifted by 1.
template <class T>
void Perturb(T& value) {
  if constexpr (std::is_same_v<T, bool>) {
    value = !value;
  } else if constexpr (std::is_enum_v<T>) {
    static_assert(NamedEnum<T>, "an enum field needs FieldEnumNames next to its VisitFields");
    const auto names = FieldEnumNames(value);
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i].value == value) {
        value = names[(i + 1) % names.size()].value;
        return;
      }
    }
    value = names.front().value;
  } else if constexpr (std::is_integral_v<T>) {
    value = static_cast<T>(value + 1);
  } else if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) {
      value = 1;
    } else if (value + 1 != value) {
      value += 1;
    } else {
      value *= 2;
    }
  } else if constexpr (std::is_same_v<T, std::string>) {
    value += "x";
  } else if constexpr (IsOptional<T>::value) {
    if (value) {
      value.reset();
    } else {
      value = SampleValue<typename T::value_type>();
    }
  } else if constexpr (IsVector<T>::value) {
    value.push_back(SampleValue<typename T::value_type>());
  } else if constexpr (EigenMatrix<T>) {
    for (int i = 0; i < static_cast<int>(value.size()); ++i) Perturb(value(i));
  } else if constexpr (EigenBox<T>) {
    value.min() -= T::VectorType::Ones();
  } else {
    static_assert(sizeof(T) == 0, "not an option leaf");
  }
}

// What is wrong with the field lists of `options` and of every struct it holds (empty when
// nothing): a member left out (the count of listed members differs from the struct's data
// members), a member listed twice or under two names, an enum value without a name.
template <Listed S>
std::vector<std::string> UnlistedFields(S& options, const std::string& path = "options") {
  std::vector<std::string> problems;
  std::vector<const void*> addresses;
  std::vector<std::string> names;
  const auto* begin = reinterpret_cast<const unsigned char*>(&options);
  const auto* end = begin + sizeof(S);
  VisitFields(options, [&](const char* name, auto& field, Role = Role::kResult) {
    using T = std::remove_cvref_t<decltype(field)>;
    const std::string here = path + "." + name;
    const auto* at = reinterpret_cast<const unsigned char*>(&field);
    if (at < begin || at >= end) problems.push_back(here + ": not a member of this struct");
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i] == name) problems.push_back(here + ": name listed twice");
      if (addresses[i] == at) problems.push_back(here + ": member listed twice");
    }
    names.emplace_back(name);
    addresses.push_back(at);
    if constexpr (Listed<T>) {
      for (std::string& p : UnlistedFields(field, here)) problems.push_back(std::move(p));
    } else if constexpr (IsVector<T>::value || IsOptional<T>::value) {
      using Item = typename T::value_type;
      if constexpr (Listed<Item>) {
        Item item{};
        for (std::string& p : UnlistedFields(item, here + "[]")) problems.push_back(std::move(p));
      }
    } else if constexpr (std::is_enum_v<T>) {
      if (std::string_view(EnumValueName(field)) == "?") {
        problems.push_back(here + ": its value is missing from FieldEnumNames");
      }
    }
  });
  const std::size_t members = MemberCount<S>();
  if (names.size() != members) {
    problems.push_back(path + ": " + std::to_string(members) + " data members but " +
                       std::to_string(names.size()) +
                       " listed: add the new member to VisitFields in the option_fields.h of "
                       "the struct's module");
  }
  return problems;
}

}  // namespace crop4d::fields
