// msgs::BoundedQueue, the hand-over of PrefetchingReader and sim::RobotStream.
#include "draco/msgs/bounded_queue.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

namespace draco::msgs {
namespace {

TEST(BoundedQueue, GivesTheItemsInOrderThenTheEnd) {
  BoundedQueue<int> queue(3);
  std::thread producer([&] {
    for (int i = 0; i < 1000; ++i) ASSERT_TRUE(queue.Push(i));
    queue.Finish();
  });
  std::vector<int> got;
  while (const auto item = queue.Pop()) got.push_back(*item);
  producer.join();
  ASSERT_EQ(got.size(), 1000u);
  for (int i = 0; i < 1000; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)], i);
  EXPECT_FALSE(queue.Pop().has_value());  // the end stays the end
}

TEST(BoundedQueue, TheProducerWaitsWhenTheQueueIsFull) {
  BoundedQueue<int> queue(2);
  std::atomic<int> pushed{0};
  std::thread producer([&] {
    for (int i = 0; i < 5; ++i) {
      if (!queue.Push(i)) return;
      ++pushed;
    }
    queue.Finish();
  });
  while (pushed.load() < 2) std::this_thread::yield();
  // Whatever the scheduling, a third item cannot be in while nothing was taken.
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_EQ(pushed.load(), 2);
  EXPECT_EQ(queue.Pop(), 0);
  while (pushed.load() < 3) std::this_thread::yield();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(pushed.load(), 3);
  for (int i = 1; i < 5; ++i) EXPECT_EQ(queue.Pop(), i);
  EXPECT_FALSE(queue.Pop().has_value());
  producer.join();
}

TEST(BoundedQueue, TheProducersErrorComesAfterItsItems) {
  BoundedQueue<int> queue(4);
  ASSERT_TRUE(queue.Push(7));
  ASSERT_TRUE(queue.Push(8));
  queue.Finish(std::make_exception_ptr(std::runtime_error("damaged record 3")));
  EXPECT_EQ(queue.Pop(), 7);
  EXPECT_EQ(queue.Pop(), 8);
  try {
    (void)queue.Pop();
    FAIL() << "the producer's error was not rethrown";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "damaged record 3");
  }
}

TEST(BoundedQueue, CloseReleasesAWaitingProducerAndDropsTheItems) {
  BoundedQueue<int> queue(1);
  std::atomic<bool> first{false}, refused{false};
  std::thread producer([&] {
    first = queue.Push(1);
    refused = !queue.Push(2);  // waits: the queue is full
    queue.Finish(std::make_exception_ptr(std::runtime_error("not seen once closed")));
  });
  while (!first.load()) std::this_thread::yield();
  queue.Close();
  producer.join();
  EXPECT_TRUE(refused.load());
  EXPECT_FALSE(queue.Pop().has_value());  // no items, no error once closed
  EXPECT_FALSE(queue.Push(3));
  queue.Close();  // idempotent
}

}  // namespace
}  // namespace draco::msgs
