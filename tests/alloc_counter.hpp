#pragma once
/// @file
/// Counting replacement of the global operator new/delete (every variant: plain, array,
/// nothrow, aligned, sized). Link alloc_counter.cpp into a test executable and use
///
///   wbm_test::AllocationCounter counter;
///   ... code that must not allocate ...
///   EXPECT_EQ(counter.count(), 0);
///
/// The replacement also serves shared libraries loaded by the executable (libwbm.so),
/// because the dynamic linker binds their operator new to the executable's definition.

#include <cstdint>

namespace wbm_test {

/// Number of successful allocations (any operator new variant) since program start,
/// in all threads.
std::int64_t allocations();
/// Number of deallocations of non-null pointers since program start.
std::int64_t deallocations();

/// Counts the allocations made while it lives.
class AllocationCounter {
 public:
  AllocationCounter() : start_(allocations()) {}
  AllocationCounter(const AllocationCounter&) = delete;
  AllocationCounter& operator=(const AllocationCounter&) = delete;
  /// Allocations since construction (or the last reset()).
  std::int64_t count() const { return allocations() - start_; }
  void reset() { start_ = allocations(); }

 private:
  std::int64_t start_;
};

}  // namespace wbm_test
