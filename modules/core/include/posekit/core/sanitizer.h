#pragma once
// POSEKIT_ADDRESS_SANITIZER is 1 in a build with AddressSanitizer, under GCC and clang alike: GCC
// defines __SANITIZE_ADDRESS__, clang 14 (Debian 12's) only answers __has_feature(address_sanitizer).
#if defined(__SANITIZE_ADDRESS__)
#define POSEKIT_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define POSEKIT_ADDRESS_SANITIZER 1
#endif
#endif
#ifndef POSEKIT_ADDRESS_SANITIZER
#define POSEKIT_ADDRESS_SANITIZER 0
#endif
