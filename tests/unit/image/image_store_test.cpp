#include "rejuv/image/image_store.hpp"
#include "rejuv/sys/event.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <sys/wait.h>

#include <cerrno>
#include <csignal>
#include <string>

namespace rejuv::image {
namespace {

// A stand-in image: a child that waits for the kernel to kill it or to close its resume socket.
Image make_image(ServiceId service) {
  auto pair = sys::SeqPacket::pair();
  EXPECT_TRUE(pair.has_value());
  const pid_t pid = ::fork();
  if (pid == 0) {
    pair->first.close();
    std::array<std::byte, 64> buf{};
    (void)pair->second.receive(buf);  // returns when the kernel's end closes
    ::_exit(0);
  }
  pair->second.close();
  auto child = sys::ChildProcess::adopt(pid);
  EXPECT_TRUE(child.has_value());
  EXPECT_TRUE(sys::set_nonblocking(pair->first.fd(), true).has_value());
  Image image{.service = service, .copies = {}, .resume = std::move(pair->first)};
  image.copies.push_back(std::move(*child));
  return image;
}

GenerationRecord make_generation(Generation g, std::size_t services) {
  GenerationRecord r{.g = g, .images = {},
                     .state = {.t_cp = Nanos{static_cast<std::int64_t>(g.value()) * 1000}, .queues = {}, .services = {}}};
  for (std::size_t i = 0; i < services; ++i) {
    r.images.push_back(make_image(ServiceId(static_cast<std::uint32_t>(i))));
    r.state.services.push_back(
        SavedService{.service = ServiceId(static_cast<std::uint32_t>(i)), .subscriptions = {}, .timers = {}});
  }
  return r;
}

TEST(ImageStore, KeepsTheNewestKGenerationsAndReapsTheRest) {
  const int fds_before = *sys::count_open_fds();
  const int children_before = *sys::count_children(::getpid());
  {
    ImageStore store(2);
    std::vector<int> first_pids;
    for (int k = 0; k < 5; ++k) {
      const Generation g = store.next_generation();
      EXPECT_EQ(g.value(), static_cast<std::uint64_t>(k + 1));
      auto rec = make_generation(g, 3);
      if (k == 0) {
        for (const Image& i : rec.images) first_pids.push_back(i.copies.front().pid());
      }
      for (GenerationRecord& old : store.commit(std::move(rec))) destroy(old);
      EXPECT_LE(store.size(), 2U);
    }
    EXPECT_EQ(store.generations(), (std::vector<Generation>{Generation{4}, Generation{5}}));
    EXPECT_EQ(store.image_count(), 6U);
    EXPECT_EQ(store.image_pids(ServiceId(1)).size(), 2U);
    for (const int pid : first_pids) EXPECT_FALSE(store.owns(pid));
    EXPECT_EQ(*sys::count_children(::getpid()), children_before + 6);
  }
  EXPECT_EQ(*sys::count_children(::getpid()), children_before);
  EXPECT_EQ(*sys::count_open_fds(), fds_before);
}

// A generation begun and abandoned (a failed checkpoint) keeps its number: the next checkpoint takes a new one,
// so that a late answer to the abandoned one cannot be read as an answer to it.
TEST(ImageStore, AnAbandonedGenerationsNumberIsNeverReused) {
  ImageStore store(2);
  const Generation first = store.next_generation();
  for (GenerationRecord& old : store.commit(make_generation(first, 1))) destroy(old);
  const Generation abandoned = store.next_generation();
  store.abandon(abandoned);
  const Generation next = store.next_generation();
  EXPECT_GT(next.value(), abandoned.value());
  for (GenerationRecord& old : store.commit(make_generation(next, 1))) destroy(old);
  EXPECT_EQ(store.generations(), (std::vector<Generation>{first, next}));
  store.abandon(first);  // an old number changes nothing
  EXPECT_EQ(store.next_generation().value(), next.value() + 1);
}

// docs/design.md §7 "Faults": while an image of the newest K is not confirmed (its Patch unanswered), one older
// generation stays, so that losing the base it is made from leaves an intact one to fall back to; never more
// than K + 1; once confirmed, trim() lets the extra one go.
TEST(ImageStore, KeepsOneMoreGenerationWhileTheNewestIsNotConfirmed) {
  ImageStore store(2);
  for (int k = 0; k < 2; ++k) EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 2)).empty());
  const auto pending = [&] {
    GenerationRecord r = make_generation(store.next_generation(), 2);
    r.images[1].patch_pending = true;  // made from written pages, its copy not reported yet
    return r;
  };
  EXPECT_TRUE(store.commit(pending()).empty()) << "generation 1 is the fallback while 3 is not confirmed";
  EXPECT_EQ(store.generations(), (std::vector<Generation>{Generation{1}, Generation{2}, Generation{3}}));
  EXPECT_TRUE(store.trim().empty());
  std::vector<GenerationRecord> out = store.commit(pending());
  ASSERT_EQ(out.size(), 1U) << "never more than K + 1";
  EXPECT_EQ(out.front().g, Generation{1});
  destroy(out.front());
  EXPECT_EQ(store.generations(), (std::vector<Generation>{Generation{2}, Generation{3}, Generation{4}}));
  store.find(Generation{3})->images[1].patch_pending = false;
  EXPECT_TRUE(store.trim().empty()) << "generation 4 is not confirmed yet";
  store.find(Generation{4})->images[1].patch_pending = false;
  out = store.trim();
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out.front().g, Generation{2});
  destroy(out.front());
  EXPECT_EQ(store.generations(), (std::vector<Generation>{Generation{3}, Generation{4}}));
}

TEST(ImageStore, FindsADeadImage) {
  ImageStore store(3);
  EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 2)).empty());
  EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 2)).empty());
  GenerationRecord* newest = store.newest();
  ASSERT_NE(newest, nullptr);
  EXPECT_FALSE(newest->dead_image().has_value());
  sys::ChildProcess& copy = newest->image_of(ServiceId(1))->copies.front();
  ASSERT_TRUE(copy.signal(SIGKILL).has_value());
  // The pidfd becomes readable once the child is gone.
  ASSERT_TRUE(sys::wait_fd(copy.pidfd(), sys::WaitFor::Readable, std::chrono::seconds(5)).has_value());
  EXPECT_EQ(newest->dead_image(), ServiceId(1));
  auto taken = store.take(newest->g);
  ASSERT_TRUE(taken.has_value());
  destroy(*taken);
  EXPECT_EQ(store.size(), 1U);
  EXPECT_EQ(store.newest()->g, Generation{1});
  EXPECT_FALSE(store.newest()->dead_image().has_value());
}

// Blocks until `copy` is stopped, leaving the stop to be reported (WNOWAIT).
void wait_stopped(const sys::ChildProcess& copy) {
  siginfo_t info{};
  ASSERT_EQ(::waitid(P_PIDFD, static_cast<id_t>(copy.pidfd()), &info, WSTOPPED | WNOWAIT), 0);
  ASSERT_EQ(info.si_code, CLD_STOPPED);
}

// A stopped frozen copy would take a Resume and never answer (the rollback would wait its whole deadline): the
// store finds it lost like a dead one, and kills it.
TEST(ImageStore, AStoppedCopy_IsLostAtOnce_AndKilled) {
  ImageStore store(2);
  EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 2)).empty());
  GenerationRecord* newest = store.newest();
  ASSERT_NE(newest, nullptr);
  sys::ChildProcess& copy = newest->image_of(ServiceId(1))->copies.front();
  const pid_t pid = copy.pid();
  ASSERT_TRUE(copy.signal(SIGSTOP).has_value());
  wait_stopped(copy);
  EXPECT_EQ(store.dead_image(*newest), ServiceId(1));
  EXPECT_NE(newest->image_of(ServiceId(1))->last_death.find("was stopped"), std::string::npos);
  EXPECT_TRUE(newest->image_of(ServiceId(1))->copies.empty());
  EXPECT_EQ(::kill(pid, 0), -1) << "the stopped copy is killed and reaped";
  EXPECT_EQ(errno, ESRCH);
  EXPECT_TRUE(newest->image_of(ServiceId(0))->has_copy_or_patch()) << "the other service's image is untouched";
}

// Generation g whose image of service 0 is by written pages, its Patch from generation 1 still on its way (no
// copy yet); the other services' images each have a copy.
GenerationRecord patched_generation(Generation g, std::size_t services) {
  GenerationRecord r = make_generation(g, services);
  Image& patched = r.images.front();
  patched.copies.front().kill_and_reap();
  patched.copies.clear();
  patched.patch_pending = true;
  patched.base = Generation{1};
  return r;
}

// An image by written pages is made by a copy of its base generation's image (Patch): with every such copy gone
// the patch never comes, so the image is dead now rather than after the rollback's resume deadline.
TEST(ImageStore, APatchWhoseBaseCopiesAreAllGone_IsDeadAtOnce) {
  ImageStore store(3);
  EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 1)).empty());
  EXPECT_TRUE(store.commit(patched_generation(store.next_generation(), 1)).empty());
  GenerationRecord* newest = store.newest();
  ASSERT_NE(newest, nullptr);
  EXPECT_FALSE(store.dead_image(*newest).has_value()) << "its base can still apply the patch";
  sys::ChildProcess& base_copy = store.find(Generation{1})->image_of(ServiceId(0))->copies.front();
  ASSERT_TRUE(base_copy.signal(SIGSTOP).has_value());
  wait_stopped(base_copy);
  EXPECT_EQ(store.dead_image(*newest), ServiceId(0));
  EXPECT_NE(newest->image_of(ServiceId(0))->last_death.find("its patch will not come"), std::string::npos)
      << newest->image_of(ServiceId(0))->last_death;
  EXPECT_EQ(store.dead_image(*store.find(Generation{1})), ServiceId(0));
}

// A rollback in real time passes over a generation whose image has no copy free to take the Resume now: one
// that is still being made (its Patch), or whose only copy forks — a spare of its own, or the next
// generation's image by written pages.
TEST(ImageStore, FreeToResume_OnlyWithACopyNoForkKeepsBusy) {
  ImageStore store(3);
  EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 2)).empty());
  GenerationRecord* first = store.find(Generation{1});
  ASSERT_NE(first, nullptr);
  EXPECT_TRUE(store.free_to_resume(*first)) << "one copy per image, nothing on its way";
  first->image_of(ServiceId(1))->spares_pending = 1;
  EXPECT_FALSE(store.free_to_resume(*first)) << "its only copy forks a spare";
  first->image_of(ServiceId(1))->copies.push_back(std::move(make_image(ServiceId(1)).copies.front()));
  EXPECT_TRUE(store.free_to_resume(*first)) << "a second copy is free while the first forks";
  first->image_of(ServiceId(1))->spares_pending = 0;

  EXPECT_TRUE(store.commit(patched_generation(store.next_generation(), 2)).empty());
  EXPECT_FALSE(store.free_to_resume(*store.find(Generation{2})))
      << "its image of service 0 is still being made";
  EXPECT_FALSE(store.free_to_resume(*store.find(Generation{1})))
      << "its only copy of service 0 forks that image";
  Image* base = store.find(Generation{1})->image_of(ServiceId(0));
  base->copies.push_back(std::move(make_image(ServiceId(0)).copies.front()));
  EXPECT_TRUE(store.free_to_resume(*store.find(Generation{1})))
      << "a second copy is free while the first forks";
}

// An image let go of with copies still on their way (a spare asked of a copy that was then resumed, its
// Patch): as many unknown processes of that service are the kernel's lost copies, no more, none of another,
// and none once UnheardCopies::kFor has passed since the last let go.
TEST(UnheardCopies, AsManyAsTheImagesLetGoOfStillWaitedFor_ByService_ForAWhile) {
  UnheardCopies unheard;
  const Nanos t0{std::chrono::seconds{100}};
  Image settled{.service = ServiceId(0)};
  unheard.let_go(settled, t0);
  EXPECT_EQ(unheard.of(ServiceId(0), t0), 0U);
  EXPECT_FALSE(unheard.take(ServiceId(0), t0)) << "nothing was on its way";
  Image waiting{.service = ServiceId(2), .spares_pending = 2, .patch_pending = true};
  unheard.let_go(waiting, t0);
  EXPECT_EQ(unheard.of(ServiceId(2), t0), 3U);
  EXPECT_FALSE(unheard.take(ServiceId(1), t0)) << "another service's";
  EXPECT_FALSE(unheard.take(ServiceId(7), t0)) << "a service never seen";
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(unheard.take(ServiceId(2), t0)) << i;
  EXPECT_FALSE(unheard.take(ServiceId(2), t0)) << "more than the kernel asked for";

  unheard.let_go(waiting, t0);
  const Nanos later = t0 + UnheardCopies::kFor / 2;
  unheard.let_go(Image{.service = ServiceId(2), .spares_pending = 1}, later);
  EXPECT_EQ(unheard.of(ServiceId(2), later), 4U) << "added to what is still owed";
  EXPECT_EQ(unheard.of(ServiceId(2), later + UnheardCopies::kFor), 0U) << "forgotten";
  EXPECT_FALSE(unheard.take(ServiceId(2), later + UnheardCopies::kFor));
  unheard.let_go(Image{.service = ServiceId(2), .spares_pending = 1}, later + UnheardCopies::kFor * 2);
  EXPECT_EQ(unheard.of(ServiceId(2), later + UnheardCopies::kFor * 2), 1U) << "what was forgotten stays so";
}

TEST(ImageStore, ClosingTheResumeSocketEndsAnImage) {
  ImageStore store(1);
  EXPECT_TRUE(store.commit(make_generation(store.next_generation(), 1)).empty());
  Image* image = store.newest()->image_of(ServiceId(0));
  image->resume.close();
  sys::ChildProcess& copy = image->copies.front();
  ASSERT_TRUE(sys::wait_fd(copy.pidfd(), sys::WaitFor::Readable, std::chrono::seconds(5)).has_value());
  auto status = copy.try_wait();
  ASSERT_TRUE(status.has_value());
  ASSERT_TRUE(status->has_value());
  EXPECT_EQ((*status)->how, sys::ExitStatus::How::Exited);
  EXPECT_EQ((*status)->value, 0);
}

}  // namespace
}  // namespace rejuv::image
