#include "posekit/core/parallel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/timer.h"

namespace posekit {
namespace {

TEST(ParallelForRanges, CoversEveryItemOnceAndRethrowsAWorkersException) {
  std::vector<int> hits(10000, 0);
  parallel_for_ranges(
      10000, 4,
      [&](long begin, long end) {
        for (long i = begin; i < end; ++i) ++hits[static_cast<size_t>(i)];
      },
      100);
  EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), 10000);
  // A throw in the last chunk (another thread) reaches the caller instead of terminating.
  EXPECT_THROW(parallel_for_ranges(
                   10000, 4,
                   [](long begin, long) {
                     if (begin >= 7500) throw InvalidInput("chunk " + std::to_string(begin));
                   },
                   100),
               InvalidInput);
}

TEST(ParallelForRanges, GivesEachThreadAtLeastTheMinimumNumberOfItems) {
  std::atomic<int> calls{0};
  parallel_for_ranges(
      10, 8,
      [&](long begin, long end) {
        ++calls;
        EXPECT_GE(end - begin, 5);
      },
      5);
  EXPECT_EQ(calls.load(), 2);
  EXPECT_NO_THROW(parallel_for_ranges(
      0, 4, [](long, long) {}, 1));
}

TEST(ParallelForEach, RunsEveryItemOnceOnEveryThreadCount) {
  for (int threads : {0, 1, 2, 5}) {
    std::vector<int> hits(257, 0);
    parallel_for_each(257, threads, [&](long i) { ++hits[static_cast<size_t>(i)]; });
    EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), 257) << threads << " threads";
  }
  EXPECT_NO_THROW(parallel_for_each(0, 2, [](long) { throw InvalidInput("no item"); }));
}

TEST(ParallelForEach, StopsHandingOutItemsAfterAnExceptionAndRethrowsIt) {
  std::atomic<int> started{0};
  EXPECT_THROW(parallel_for_each(1000, 2,
                                 [&](long i) {
                                   ++started;
                                   if (i == 3) throw InvalidInput("item 3");
                                   std::this_thread::sleep_for(std::chrono::microseconds(200));
                                 }),
               InvalidInput);
  EXPECT_LT(started.load(), 1000);
}

TEST(RunBeside, RunsBothAndRethrowsTheMainWorksExceptionFirst) {
  for (int threads : {1, 2}) {
    int a = 0, b = 0;
    run_beside(
        threads, [&] { a = 1; }, [&] { b = 2; });
    EXPECT_EQ(a + b, 3);
    try {
      run_beside(
          threads, [] { throw IoError("beside"); }, [] { throw InvalidInput("main"); });
      ADD_FAILURE() << "no exception";
    } catch (const InvalidInput& e) {
      EXPECT_STREQ(e.what(), "main");
    }
    EXPECT_THROW(run_beside(
                     threads, [] { throw IoError("beside"); }, [] {}),
                 IoError);
  }
}

TEST(StageTimer, AddsUpRepeatsInTheOrderStagesFirstEnded) {
  StageTimer timer;
  timer.lap("search");
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  timer.lap("fit");
  timer.lap("search");
  ASSERT_EQ(timer.stages().size(), 2u);
  EXPECT_EQ(timer.stages()[0].first, "search");
  EXPECT_EQ(timer.stages()[1].first, "fit");
  EXPECT_GE(timer.stages()[1].second, 0.002);
  Stopwatch watch;
  EXPECT_GE(watch.seconds(), 0.0);
}

}  // namespace
}  // namespace posekit
