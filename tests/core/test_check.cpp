#include <catch2/catch.hpp>

#include "shearzone/core/check.hpp"

using Catch::Matchers::Contains;

TEST_CASE("SHEARZONE_CHECK throws InternalError naming the condition", "[core]") {
  const int n = 3;
  CHECK_NOTHROW([&] { SHEARZONE_CHECK(n == 3); }());
  CHECK_THROWS_MATCHES([&] { SHEARZONE_CHECK(n == 4); }(), shearzone::InternalError,
                       Catch::Matchers::Predicate<shearzone::InternalError>(
                           [](const shearzone::InternalError& e) {
                             return std::string(e.what()).find("n == 4") != std::string::npos;
                           }));
}

TEST_CASE("SHEARZONE_CHECK_OP prints both operands", "[core]") {
  const int a = 2, b = 5;
  try {
    SHEARZONE_CHECK_OP(a, >, b);
    FAIL("expected a throw");
  } catch (const shearzone::InternalError& e) {
    CHECK_THAT(e.what(), Contains("a > b") && Contains("2 vs 5"));
  }
}

#if defined(SHEARZONE_ENABLE_DCHECK) || !defined(NDEBUG)
TEST_CASE("SHEARZONE_DCHECK is on in the test build", "[core]") {
  CHECK_THROWS_AS([] { SHEARZONE_DCHECK(1 == 2); }(), shearzone::InternalError);
}
#endif
