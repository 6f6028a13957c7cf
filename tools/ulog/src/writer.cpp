#include "rejuv/ulog/writer.hpp"

#include <bit>
#include <cstring>

namespace rejuv::ulog {
namespace {

static_assert(std::endian::native == std::endian::little, "ULog is little endian; so is every target of Rejuv");

void put(std::vector<std::byte>& out, const void* data, std::size_t n) {
  const auto* p = static_cast<const std::byte*>(data);
  out.insert(out.end(), p, p + n);
}
template <class T>
void put_value(std::vector<std::byte>& out, T v) {
  put(out, &v, sizeof v);
}

bool valid_name(std::string_view name) {
  return !name.empty() && name.find_first_of(":; []") == std::string_view::npos;
}

}  // namespace

std::string_view to_string(UlogError e) {
  switch (e) {
    case UlogError::TooLong: return "too long for its ULog length field";
    case UlogError::BadName: return "not a valid ULog name";
    case UlogError::UnknownType: return "a field type that is neither basic nor a defined format";
    case UlogError::DuplicateFormat: return "a format of that name exists";
    case UlogError::UnknownFormat: return "no format of that name";
    case UlogError::NotADefinition: return "a definition after the data section began";
    case UlogError::UnknownMsgId: return "no subscription with that msg_id";
    case UlogError::WrongSize: return "data of a size other than its format's";
    case UlogError::TooManySubscriptions: return "more than 65536 subscriptions";
    case UlogError::Io: return "the file could not be written";
  }
  return "?";
}

std::size_t basic_size(std::string_view type) {
  if (type == "int8_t" || type == "uint8_t" || type == "bool" || type == "char") return 1;
  if (type == "int16_t" || type == "uint16_t") return 2;
  if (type == "int32_t" || type == "uint32_t" || type == "float") return 4;
  if (type == "int64_t" || type == "uint64_t" || type == "double") return 8;
  return 0;
}

std::string format_text(const Format& format) {
  std::string s = format.name + ":";
  for (const Field& f : format.fields) {
    s += f.type;
    if (f.array > 0) s += "[" + std::to_string(f.array) + "]";
    s += " " + f.name + ";";
  }
  return s;
}

std::string_view truncate_utf8(std::string_view text, std::size_t max) {
  if (text.size() <= max) return text;
  std::size_t n = max;
  // Back off continuation bytes (10xxxxxx) so that the cut falls before the lead byte of a sequence.
  while (n > 0 && (static_cast<unsigned char>(text[n]) & 0xC0) == 0x80) --n;
  return text.substr(0, n);
}

Encoder::Encoder(std::uint64_t start_us) {
  put(out_, kMagic.data(), kMagic.size());
  put_value<std::uint8_t>(out_, 1);  // version
  put_value(out_, start_us);
  // 'B': compat_flags[8], incompat_flags[8], appended_offsets[3] (uint64): all zero.
  scratch_.assign(8 + 8 + 3 * 8, std::byte{0});
  message('B', scratch_);
}

void Encoder::message(char type, std::span<const std::byte> payload) {
  REJUV_ASSERT(payload.size() <= kMaxPayload, "a ULog message longer than its size field");
  put_value(out_, static_cast<std::uint16_t>(payload.size()));
  put_value(out_, static_cast<std::uint8_t>(type));
  put(out_, payload.data(), payload.size());
}

Result<void, UlogError> Encoder::key_value(char type, std::string_view key, std::span<const std::byte> value,
                                           bool definition) {
  if (definition && data_section_) return fail(UlogError::NotADefinition);
  if (key.size() > kMaxKey) return fail(UlogError::TooLong);
  if (1 + key.size() + value.size() > kMaxPayload) return fail(UlogError::TooLong);
  scratch_.clear();
  put_value(scratch_, static_cast<std::uint8_t>(key.size()));
  put(scratch_, key.data(), key.size());
  put(scratch_, value.data(), value.size());
  message(type, scratch_);
  return {};
}

Result<void, UlogError> Encoder::info_string(std::string_view key, std::string_view value) {
  if (!valid_name(key)) return fail(UlogError::BadName);
  // The key says the length ("char[5] sys_name"): cut the value so that key and value fit one message.
  const std::string prefix = "char[";
  const std::size_t room = kMaxPayload - 1 - (prefix.size() + 7 + key.size());
  const std::string_view v = truncate_utf8(value, room);
  const std::string full = prefix + std::to_string(v.size()) + "] " + std::string(key);
  return key_value('I', full, std::as_bytes(std::span(v.data(), v.size())), true);
}

Result<void, UlogError> Encoder::info_u64(std::string_view key, std::uint64_t value) {
  if (!valid_name(key)) return fail(UlogError::BadName);
  return key_value('I', "uint64_t " + std::string(key), std::as_bytes(std::span(&value, 1)), true);
}

Result<void, UlogError> Encoder::parameter(std::string_view name, float value) {
  if (!valid_name(name)) return fail(UlogError::BadName);
  // Parameters may also change in the data section (the spec allows 'P' there).
  return key_value('P', "float " + std::string(name), std::as_bytes(std::span(&value, 1)), false);
}

Result<void, UlogError> Encoder::parameter(std::string_view name, std::int32_t value) {
  if (!valid_name(name)) return fail(UlogError::BadName);
  return key_value('P', "int32_t " + std::string(name), std::as_bytes(std::span(&value, 1)), false);
}

Result<void, UlogError> Encoder::format(const Format& format) {
  if (data_section_) return fail(UlogError::NotADefinition);
  if (!valid_name(format.name)) return fail(UlogError::BadName);
  if (format_sizes_.contains(format.name)) return fail(UlogError::DuplicateFormat);
  std::size_t size = 0;
  for (const Field& f : format.fields) {
    if (!valid_name(f.name) || !valid_name(f.type)) return fail(UlogError::BadName);
    std::size_t one = basic_size(f.type);
    if (one == 0) {
      const auto it = format_sizes_.find(f.type);
      if (it == format_sizes_.end()) return fail(UlogError::UnknownType);
      one = it->second;
    }
    size += one * (f.array == 0 ? 1 : f.array);
  }
  const std::string text = format_text(format);
  if (text.size() > kMaxPayload) return fail(UlogError::TooLong);
  message('F', std::as_bytes(std::span(text.data(), text.size())));
  format_sizes_.emplace(format.name, size);
  return {};
}

std::size_t Encoder::format_size(std::string_view name) const {
  const auto it = format_sizes_.find(name);
  return it == format_sizes_.end() ? 0 : it->second;
}

Result<MsgId, UlogError> Encoder::add_logged(std::string_view format_name, std::uint8_t multi_id) {
  const auto it = format_sizes_.find(format_name);
  if (it == format_sizes_.end()) return fail(UlogError::UnknownFormat);
  if (subscription_sizes_.size() > 0xFFFF) return fail(UlogError::TooManySubscriptions);
  const auto id = static_cast<MsgId>(subscription_sizes_.size());
  data_section_ = true;
  scratch_.clear();
  put_value(scratch_, multi_id);
  put_value(scratch_, id);
  put(scratch_, format_name.data(), format_name.size());
  message('A', scratch_);
  subscription_sizes_.push_back(it->second);
  return id;
}

Result<void, UlogError> Encoder::data(MsgId id, std::span<const std::byte> payload) {
  if (id >= subscription_sizes_.size()) return fail(UlogError::UnknownMsgId);
  if (payload.size() != subscription_sizes_[id]) return fail(UlogError::WrongSize);
  if (payload.size() + 2 > kMaxPayload) return fail(UlogError::TooLong);
  data_section_ = true;
  put_value(out_, static_cast<std::uint16_t>(payload.size() + 2));
  put_value(out_, static_cast<std::uint8_t>('D'));
  put_value(out_, id);
  put(out_, payload.data(), payload.size());
  return {};
}

void Encoder::log(LogLevel level, std::uint64_t t_us, std::string_view text) {
  data_section_ = true;
  const std::string_view t = truncate_utf8(text, kMaxPayload - 1 - 8);
  scratch_.clear();
  put_value(scratch_, static_cast<std::uint8_t>(level));
  put_value(scratch_, t_us);
  put(scratch_, t.data(), t.size());
  message('L', scratch_);
}

void Encoder::sync() {
  data_section_ = true;
  message('S', std::as_bytes(std::span(kSyncMagic)));
}

std::vector<std::byte> Encoder::take() {
  std::vector<std::byte> taken;
  taken.swap(out_);
  out_.reserve(taken.capacity());
  return taken;
}

Result<FileWriter, UlogError> FileWriter::create(const std::filesystem::path& path, std::uint64_t start_us) {
  std::unique_ptr<std::FILE, Closer> f(std::fopen(path.c_str(), "wb"));
  if (!f) return fail(UlogError::Io);
  return FileWriter(std::move(f), path, start_us);
}

void FileWriter::flush() {
  const std::vector<std::byte> bytes = enc_.take();
  if (failed_ || !file_ || bytes.empty()) return;
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_.get()) != bytes.size()) failed_ = true;
  written_ += bytes.size();
}

void FileWriter::flush_if_large() {
  if (enc_.bytes().size() >= 256 * 1024) flush();
}

Result<std::uint64_t, UlogError> FileWriter::close() {
  flush();
  if (file_ && std::fclose(file_.release()) != 0) failed_ = true;
  if (failed_) return fail(UlogError::Io);
  return written_;
}

}  // namespace rejuv::ulog
