#include "rejuv/image/image_store.hpp"

#include <algorithm>

#include "rejuv/core/result.hpp"

namespace rejuv::image {

Image* GenerationRecord::image_of(ServiceId service) {
  for (Image& i : images) {
    if (i.service == service) return &i;
  }
  return nullptr;
}

const SavedService* GenerationRecord::saved(ServiceId service) const {
  for (const SavedService& s : services) {
    if (s.service == service) return &s;
  }
  return nullptr;
}

std::optional<ServiceId> GenerationRecord::dead_image() {
  for (Image& i : images) {
    if (!i.process.running()) return i.service;
    auto status = i.process.try_wait();
    if (!status || *status) return i.service;
  }
  return std::nullopt;
}

void destroy(GenerationRecord& record) {
  for (Image& i : record.images) {
    i.resume.close();  // an image blocked on it exits by itself; the kill makes sure
    i.process.kill_and_reap();
  }
  record.images.clear();
}

ImageStore::ImageStore(std::size_t keep) : keep_(std::max<std::size_t>(keep, 1)) {}

std::vector<GenerationRecord> ImageStore::commit(GenerationRecord record) {
  REJUV_ASSERT(record.g == next_generation(), "generations are committed in order");
  next_ = record.g.value() + 1;
  generations_.push_back(std::move(record));
  std::vector<GenerationRecord> out;
  while (generations_.size() > keep_) {
    out.push_back(std::move(generations_.front()));
    generations_.erase(generations_.begin());
  }
  return out;
}

GenerationRecord* ImageStore::newest() { return generations_.empty() ? nullptr : &generations_.back(); }

void ImageStore::discard(Generation g) {
  for (auto it = generations_.begin(); it != generations_.end(); ++it) {
    if (it->g == g) {
      destroy(*it);
      generations_.erase(it);
      return;
    }
  }
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
      if (i.service == service) out.push_back(i.process.pid());
    }
  }
  return out;
}

bool ImageStore::owns(int pid) const {
  return std::any_of(generations_.begin(), generations_.end(), [&](const GenerationRecord& r) {
    return std::any_of(r.images.begin(), r.images.end(), [&](const Image& i) { return i.process.pid() == pid; });
  });
}

}  // namespace rejuv::image
