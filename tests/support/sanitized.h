// Whether this test program was built with AddressSanitizer: its quarantine
// keeps freed memory and its checks slow every call, so tests that measure
// memory or time allow for it.
#pragma once

namespace arscout::testing {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

}  // namespace arscout::testing
