#include "rejuv/image/image_store.hpp"

#include <algorithm>
#include <array>
#include <cerrno>

#include "rejuv/channel/wire.hpp"

#include "rejuv/core/result.hpp"

namespace rejuv::image {

namespace {
// The image of `service` in `images` (const or not), nullptr without one.
template <typename Images>
auto image_in(Images& images, ServiceId service) -> decltype(&images.front()) {
  for (auto& i : images) {
    if (i.service == service) return &i;
  }
  return nullptr;
}
}  // namespace

Image* GenerationRecord::image_of(ServiceId service) { return image_in(images, service); }

const Image* GenerationRecord::image_of(ServiceId service) const { return image_in(images, service); }

const SavedService* CheckpointedState::saved(ServiceId service) const {
  for (const SavedService& s : services) {
    if (s.service == service) return &s;
  }
  return nullptr;
}

std::size_t Image::refresh() {
  std::array<std::byte, sizeof(wire::FrameHeader) + sizeof(wire::TakenBody)> buf{};
  while (resume.valid()) {
    auto got = resume.receive(buf);
    if (!got || got->closed) break;  // EAGAIN: nothing more
    auto frame = wire::decode(std::span<const std::byte>(buf.data(), got->size), wire::Direction::ToKernel);
    if (!frame || frame->kind != wire::FrameKind::Copied) continue;  // a frozen copy has nothing else to say
    if (patch_pending) {
      patch_pending = false;  // the first Copied on a patched image's socket is the image itself
    } else if (spares_pending > 0) {
      --spares_pending;
    }
    const pid_t pid = wire::payload_as<wire::TakenBody>(*frame).image_pid;
    if (pid <= 0) {
      const auto e = static_cast<int>(wire::payload_as<wire::TakenBody>(*frame).reserved);
      last_death = "a copy could not fork: " + sys::SysError{"fork", e}.to_string();
      continue;
    }
    const bool known = std::find(resumed.begin(), resumed.end(), pid) != resumed.end() ||
                       std::any_of(copies.begin(), copies.end(), [&](const sys::ChildProcess& c) { return c.pid() == pid; });
    auto child = known ? sys::SysResult<sys::ChildProcess>(std::unexpected(sys::SysError{"known", EEXIST}))
                       : sys::ChildProcess::adopt_child(pid);
    if (child) {
      copies.push_back(std::move(*child));
      continue;
    }
    if (!known) last_death = "copy " + std::to_string(pid) + " could not be adopted: " + child.error().to_string();
    if (sys::out_of_fds(child.error().error)) {
      // The kernel's own copy, which it has no fd to keep: killed now, not left for a sweep to count as a
      // stray. The generation then lacks a copy, which its rollback reports (unusable, fallback).
      (void)sys::kill_and_reap_own_child(pid);
    }
  }
  std::erase_if(copies, [&](sys::ChildProcess& c) {
    if (!c.running()) return true;
    auto status = c.try_wait();
    if (status && !status->has_value()) {
      // A frozen copy never stops itself: one that was stopped would take a Resume and never answer, and the
      // rollback would wait its whole deadline for it. It is lost like a dead one, at once.
      const auto stopped = c.stopped_since_last_look();
      if (!stopped || !*stopped) return false;
      c.kill_and_reap();
      last_death = "copy " + std::to_string(c.pid()) + " was stopped (killed: a frozen copy never stops itself)";
      return true;
    }
    last_death = "copy " + std::to_string(c.pid()) + " " + (status ? (*status)->to_string() : status.error().to_string());
    return true;
  });
  return copies.size();
}

bool Image::request_spare(Generation g) {
  // No copy to read the Fork (as far as the last refresh knows): no spare will come of it.
  if (!has_copy_or_patch()) return false;
  wire::FrameBuffer tx;
  if (!tx.build(wire::FrameKind::Fork, 0, 0, g.value()) || !resume.send(tx.bytes())) return false;
  ++spares_pending;
  return true;
}

std::optional<ServiceId> GenerationRecord::dead_image() {
  for (Image& i : images) {
    (void)i.refresh();
    if (!i.has_copy_or_patch()) return i.service;
  }
  return std::nullopt;
}

std::optional<ServiceId> ImageStore::dead_image(GenerationRecord& record) {
  if (const auto dead = record.dead_image()) return dead;
  for (Image& i : record.images) {
    if (!i.copies.empty() || !i.patch_pending) continue;
    GenerationRecord* base = find(i.base);
    Image* from = base != nullptr ? base->image_of(i.service) : nullptr;
    if (from == nullptr) continue;
    (void)from->refresh();
    if (from->has_copy_or_patch()) continue;
    i.last_death = "its patch will not come: every copy of generation " + std::to_string(i.base.value()) +
                   "'s image is gone" + (from->last_death.empty() ? "" : " (" + from->last_death + ")");
    return i.service;
  }
  return std::nullopt;
}

void destroy(GenerationRecord& record) {
  for (Image& i : record.images) {
    i.resume.close();  // a copy blocked on it exits by itself; the kill makes sure
    for (sys::ChildProcess& c : i.copies) c.kill_and_reap();
  }
  record.images.clear();
}

ImageStore::ImageStore(std::size_t keep) : keep_(std::max<std::size_t>(keep, 1)) {}

std::vector<GenerationRecord> ImageStore::commit(GenerationRecord record) {
  REJUV_ASSERT(record.g.value() >= next_, "generations are committed in order");
  next_ = record.g.value() + 1;
  generations_.push_back(std::move(record));
  return trim();
}

std::vector<GenerationRecord> ImageStore::trim() {
  const auto newest_confirmed = [&] {
    return std::all_of(generations_.end() - static_cast<std::ptrdiff_t>(keep_), generations_.end(),
                       [](const GenerationRecord& r) {
                         return std::all_of(r.images.begin(), r.images.end(), [](const Image& i) { return i.confirmed(); });
                       });
  };
  std::vector<GenerationRecord> out;
  while (generations_.size() > keep_ + 1 || (generations_.size() > keep_ && newest_confirmed())) {
    out.push_back(std::move(generations_.front()));
    generations_.erase(generations_.begin());
  }
  return out;
}

GenerationRecord* ImageStore::newest() { return generations_.empty() ? nullptr : &generations_.back(); }
const GenerationRecord* ImageStore::newest() const {
  return generations_.empty() ? nullptr : &generations_.back();
}

bool ImageStore::free_to_resume(const GenerationRecord& record) const {
  return std::all_of(record.images.begin(), record.images.end(), [&](const Image& i) {
    if (i.patch_pending) return false;
    const auto patches_from_it =
        std::count_if(generations_.begin(), generations_.end(), [&](const GenerationRecord& r) {
          const Image* made = r.image_of(i.service);
          return made != nullptr && made->patch_pending && made->base == record.g;
        });
    return i.copies.size() > i.spares_pending + static_cast<std::size_t>(patches_from_it);
  });
}

GenerationRecord* ImageStore::find(Generation g) {
  for (GenerationRecord& r : generations_) {
    if (r.g == g) return &r;
  }
  return nullptr;
}
const GenerationRecord* ImageStore::find(Generation g) const {
  for (const GenerationRecord& r : generations_) {
    if (r.g == g) return &r;
  }
  return nullptr;
}

std::optional<GenerationRecord> ImageStore::take(Generation g) {
  for (auto it = generations_.begin(); it != generations_.end(); ++it) {
    if (it->g == g) {
      GenerationRecord out = std::move(*it);
      generations_.erase(it);
      return out;
    }
  }
  return std::nullopt;
}

std::vector<GenerationRecord> ImageStore::take_all() {
  std::vector<GenerationRecord> out = std::move(generations_);
  generations_.clear();
  return out;
}

void ImageStore::clear() {
  for (GenerationRecord& r : generations_) destroy(r);
  generations_.clear();
}

std::size_t ImageStore::image_count() const {
  std::size_t n = 0;
  for (const GenerationRecord& r : generations_) n += r.images.size();
  return n;
}

void ImageStore::refresh_all() {
  for (GenerationRecord& r : generations_) {
    for (Image& i : r.images) (void)i.refresh();
  }
}

std::size_t ImageStore::spares_pending() const {
  std::size_t n = 0;
  for (const GenerationRecord& r : generations_) {
    for (const Image& i : r.images) {
      if (i.has_copy_or_patch()) n += i.spares_pending + (i.patch_pending ? 1 : 0);
    }
  }
  return n;
}

std::vector<Generation> ImageStore::generations() const {
  std::vector<Generation> out;
  out.reserve(generations_.size());
  for (const GenerationRecord& r : generations_) out.push_back(r.g);
  return out;
}

std::vector<int> ImageStore::image_pids(ServiceId service) const {
  std::vector<int> out;
  for (const GenerationRecord& r : generations_) {
    for (const Image& i : r.images) {
      if (i.service != service) continue;
      for (const sys::ChildProcess& c : i.copies) out.push_back(c.pid());
    }
  }
  return out;
}

std::vector<int> ImageStore::image_pids(ServiceId service, Generation g) const {
  std::vector<int> out;
  for (const GenerationRecord& r : generations_) {
    if (r.g != g) continue;
    for (const Image& i : r.images) {
      if (i.service != service) continue;
      for (const sys::ChildProcess& c : i.copies) out.push_back(c.pid());
    }
  }
  return out;
}

bool ImageStore::owns(int pid) const {
  return std::any_of(generations_.begin(), generations_.end(), [&](const GenerationRecord& r) {
    return std::any_of(r.images.begin(), r.images.end(), [&](const Image& i) {
      return std::any_of(i.copies.begin(), i.copies.end(), [&](const sys::ChildProcess& c) { return c.pid() == pid; });
    });
  });
}

void UnheardCopies::let_go(const Image& im, Nanos now) {
  const std::size_t n = im.spares_pending + (im.patch_pending ? 1 : 0);
  if (n == 0) return;
  const std::size_t at = im.service.value();
  if (by_service_.size() <= at) by_service_.resize(at + 1);
  Owed& owed = by_service_[at];
  owed.copies = (now < owed.until ? owed.copies : 0) + n;
  owed.until = now + kFor;
}

bool UnheardCopies::take(ServiceId service, Nanos now) {
  if (of(service, now) == 0) return false;
  --by_service_[service.value()].copies;
  return true;
}

std::size_t UnheardCopies::of(ServiceId service, Nanos now) const {
  const std::size_t at = service.value();
  if (at >= by_service_.size() || now >= by_service_[at].until) return 0;
  return by_service_[at].copies;
}

}  // namespace rejuv::image
