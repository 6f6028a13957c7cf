// The image store (docs/design.md §7; the paper's §V checkpoint of the controller's code and data): generations of
// frozen service images with the kernel state saved beside them.
//
// A generation g is what one checkpoint produced: for every rejuvenated service its image — a process the
// service forked at the cut (clone(CLONE_PARENT), so the kernel's child), blocked on its resume socket —
// and, beside the images, the broker's queue state (rings, generations, cursors), each service's kernel
// objects (subscriptions, timers) and the time of the cut t_cp. The store keeps the newest K generations
// (launch `sr.keep_generations`, default 2; one more until the newest K are confirmed: trim()); an older
// one is discarded: its images are killed and reaped
// and their resume sockets closed. A generation whose image died (killed, crashed) is broken: a rollback
// falls back to the previous one (docs/design.md §7 "Faults").
//
// The store owns processes and fds but runs no protocol: the kernel's image coordinator (rejuvenator.cpp)
// sends Snapshot/Resume and decides when to commit, roll back and fall back.
#pragma once

#include <algorithm>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "rejuv/broker/broker.hpp"
#include "rejuv/clock/timers.hpp"
#include "rejuv/core/ids.hpp"
#include "rejuv/core/time.hpp"
#include "rejuv/sys/channel.hpp"
#include "rejuv/sys/process.hpp"

namespace rejuv::image {

// One subscription of a service, as the kernel records it (the service's cap slot, the topic, the broker's
// subscriber id).
struct SavedSubscription {
  Slot slot{};
  ObjectId topic{};
  broker::SubscriberId id{};
  friend bool operator==(const SavedSubscription&, const SavedSubscription&) = default;
};

// A service's kernel objects at the cut (docs/design.md §7 step 3).
struct SavedService {
  ServiceId service{};
  std::vector<SavedSubscription> subscriptions{};
  std::vector<clock::KernelTimer> timers{};
};

// One service's frozen image of a generation: the process the service forked at the cut and the spares it
// forked in turn (Fork/Copied), all blocked on one shared resume socket. A rollback resumes one of them
// (whichever reads the Resume) and asks a survivor for a new spare, so no fork is on the rollback's
// critical path and g stays restorable.
struct Image {
  ServiceId service{};
  std::vector<sys::ChildProcess> copies{};  // the kernel's children; killed and reaped when the generation goes
  sys::SeqPacket resume{};                  // the kernel's end of the shared resume socket (non-blocking)
  std::size_t spares_pending = 0;           // Fork sent, Copied not read yet
  std::vector<int> resumed{};               // copies that became live services: never adopted as copies again
  // An image taken by written pages (TakenPages) is made off the critical path: a copy of the base
  // generation's image forks and applies the pages (Patch), and that copy answers Copied on this image's
  // resume socket. Until then `copies` is empty and the image is pending, not dead.
  Generation base{};                        // the generation offered in the Snapshot (0: none)
  sys::UniqueFd pages{};                    // the sealed pages, until the Patch is sent
  std::uint64_t page_count = 0;
  sys::UniqueFd image_end{};                // the resume socket's image end, until Taken or the Patch
  bool patch_pending = false;               // Patch sent, Copied not read yet
  std::string last_death{};                 // how the last copy found dead ended (for the kernel's reports)
  // A copy to resume, or one on its way (the Patch's): the image is not dead (as far as the last refresh knows).
  [[nodiscard]] bool has_copy_or_patch() const { return !copies.empty() || patch_pending; }
  // A copy to resume and no Patch on its way (as far as the last refresh knows): the image exists for sure.
  [[nodiscard]] bool confirmed() const { return !copies.empty() && !patch_pending; }
  // Reads the Copied answers that have arrived (adopting each new spare) and drops the copies that died.
  // Returns how many copies are alive.
  std::size_t refresh();
  // Asks one copy of generation g for a spare (answered by Copied, read by refresh()); false, nothing asked,
  // where no copy is there or on its way to read the Fork.
  bool request_spare(Generation g);
};

// The kernel state a generation saves beside its images, as one value (docs/design.md §7 step 3; like Drake's
// Context): saved whole at the commit and restored whole by a rollback (the kernel's images.hpp,
// save_state / restore_state), so that nothing of it is assembled or restored field by field elsewhere.
struct CheckpointedState {
  Nanos t_cp{0};                         // kernel clock at the cut
  broker::BrokerSnapshot queues{};       // rings, generations, cursors
  std::vector<SavedService> services{};  // the kernel objects of every imaged service
  [[nodiscard]] const SavedService* saved(ServiceId service) const;
};

struct GenerationRecord {
  Generation g{};
  std::vector<Image> images{};
  CheckpointedState state{};

  [[nodiscard]] Image* image_of(ServiceId service);
  [[nodiscard]] const Image* image_of(ServiceId service) const;
  [[nodiscard]] const SavedService* saved(ServiceId service) const { return state.saved(service); }
  // The first service none of whose copies still runs and none is on its way, if any: the generation is broken.
  [[nodiscard]] std::optional<ServiceId> dead_image();
};

class ImageStore {
 public:
  explicit ImageStore(std::size_t keep);
  ImageStore(const ImageStore&) = delete;
  ImageStore& operator=(const ImageStore&) = delete;
  ImageStore(ImageStore&&) = default;
  ImageStore& operator=(ImageStore&&) = default;
  ~ImageStore() { clear(); }

  [[nodiscard]] std::size_t keep() const { return keep_; }
  // The number the next checkpoint uses (1, 2, …; never reused).
  [[nodiscard]] Generation next_generation() const { return Generation{next_}; }
  // A generation that was begun and abandoned: its number is never used again, so that a late answer to it
  // can never be taken for an answer to the next checkpoint (whose images would then be of two moments).
  void abandon(Generation g) { next_ = std::max(next_, g.value() + 1); }
  // Adds a complete generation (its number must be next_generation()) and returns what trim() lets go, with
  // their images still to be killed and reaped (destroy(), or the caller's own asynchronous reaping: a
  // checkpoint need not wait for old images to die).
  [[nodiscard]] std::vector<GenerationRecord> commit(GenerationRecord record);
  // The oldest generations beyond K leave the store once the newest K are confirmed (every image has a copy
  // to resume; one by written pages has none until its Patch is answered): until then one more is kept, so
  // that the loss of a base image while its successor is being made from it — both generations then lack
  // that service — leaves an intact generation to fall back to instead of a cold restart (docs/design.md §7
  // "Faults"). Never more than K + 1. The caller refreshes first (refresh_all).
  [[nodiscard]] std::vector<GenerationRecord> trim();
  // The newest generation, or nullptr.
  [[nodiscard]] GenerationRecord* newest();
  [[nodiscard]] const GenerationRecord* newest() const;
  // Generation g, or nullptr.
  [[nodiscard]] GenerationRecord* find(Generation g);
  [[nodiscard]] const GenerationRecord* find(Generation g) const;
  // The first service of `record` whose image cannot be resumed: none of its copies runs and none is on its way
  // (GenerationRecord::dead_image), or its Patch is on its way but every copy of the base generation's image that
  // would apply it is gone (then it never comes: the rollback falls back at once instead of waiting for it).
  [[nodiscard]] std::optional<ServiceId> dead_image(GenerationRecord& record);
  // Whether every image of `record` has a copy free to take a Resume now (as far as the last refresh knows):
  // no Patch of its own on its way, and more copies than Forks keep busy — a Fork for a spare of its own, or
  // a Patch that makes a newer generation's image from it. A busy copy reads the Resume only once its fork
  // returns, and a fork on a busy machine can wait a second for the locks of the files every process maps.
  [[nodiscard]] bool free_to_resume(const GenerationRecord& record) const;
  // Takes a generation (or all) out of the store; the caller destroys it (destroy(), or retires it once its
  // pending spares have reported, so that no forked copy goes unreaped).
  [[nodiscard]] std::optional<GenerationRecord> take(Generation g);
  [[nodiscard]] std::vector<GenerationRecord> take_all();
  void clear();

  [[nodiscard]] std::size_t size() const { return generations_.size(); }
  [[nodiscard]] std::size_t image_count() const;
  [[nodiscard]] std::vector<Generation> generations() const;  // oldest first
  void refresh_all();  // Image::refresh of every image
  [[nodiscard]] std::size_t spares_pending() const;
  // pids of every frozen copy of a service, oldest generation first; of one generation (tests, faults).
  [[nodiscard]] std::vector<int> image_pids(ServiceId service) const;
  [[nodiscard]] std::vector<int> image_pids(ServiceId service, Generation g) const;
  // Whether `pid` is one of the store's images.
  [[nodiscard]] bool owns(int pid) const;

 private:
  std::size_t keep_;
  std::uint64_t next_ = 1;
  std::vector<GenerationRecord> generations_;  // oldest first
};

// Kills and reaps every image of a record and closes its resume sockets.
void destroy(GenerationRecord& record);

// The copies the kernel asked for (a spare's Fork, an image's Patch) of images it let go before those copies
// reported (Copied), by service. Each one may exist — the kernel's child, in its service's session, that no
// record names — or never will (its parent died before it forked). Only the kernel's letting go of an image
// adds one; nothing a service does can. The kernel's sweep takes one for each unknown process it finds in a
// service's session that it does not count as a stray (warden.cpp): killed just the same. They are forgotten
// kFor after the last one was added: a fork that has not returned by then is not waited for (a copy that
// comes later is counted as a stray), and a service's later strays are counted.
class UnheardCopies {
 public:
  static constexpr Nanos kFor = std::chrono::seconds{5};
  // What `im` still waited for when it was let go at `now`: its spares and its Patch on their way.
  void let_go(const Image& im, Nanos now);
  // One of `service`'s not forgotten at `now`, if any is left: taken, true.
  [[nodiscard]] bool take(ServiceId service, Nanos now);
  [[nodiscard]] std::size_t of(ServiceId service, Nanos now) const;

 private:
  struct Owed {
    std::size_t copies = 0;
    Nanos until{0};
  };
  std::vector<Owed> by_service_;
};

}  // namespace rejuv::image
