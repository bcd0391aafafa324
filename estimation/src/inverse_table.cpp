// InverseTable (inverse_table.hpp): its settings, key space and lookup, and
// its cache file. The build is in inverse_table_build.cpp.
#include "chromo/estimation/inverse_table.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <system_error>

#include "inverse_table_internal.hpp"

namespace chromo::estimation {

using namespace detail;

bool InverseTableSettings::IsValid(std::string* error) const {
  bool all_zero = true;
  for (double s : relative_sigma) {
    if (!(s >= 0 && std::isfinite(s))) {
      if (error) *error = "relative_sigma must be finite and >= 0";
      return false;
    }
    all_zero = all_zero && s == 0;
  }
  if (!all_zero && *std::min_element(relative_sigma.begin(), relative_sigma.end()) == 0) {
    if (error) *error = "relative_sigma must be all zero or all > 0";
    return false;
  }
  return true;
}

std::array<double, 4> InverseTableSettings::from_noise(const MeasurementSet& set) {
  std::array<double, 4> sigma{};
  for (int c = 0; c < std::min(set.size(), 4); ++c) sigma[c] = std::sqrt(set.channels[c].noise.variance(0.2)) / 0.2;
  return sigma;
}

InverseTableSettings InverseTableSettings::completed_for(const MeasurementSet& set) const {
  InverseTableSettings out = *this;
  if (set.size() == 4 && std::all_of(relative_sigma.begin(), relative_sigma.end(), [](double s) { return s == 0; }))
    out.relative_sigma = from_noise(set);
  return out;
}

std::array<double, 4> InverseTableSettings::quantised_sigma() const {
  std::array<double, 4> q = {1, 1, 1, 1};
  const double smallest = *std::min_element(relative_sigma.begin(), relative_sigma.end());
  if (!(smallest > 0)) return q;
  for (int c = 0; c < 4; ++c) q[c] = std::exp2(std::round(2 * std::log2(relative_sigma[c] / smallest)) / 2);
  return q;
}

std::uint64_t InverseTable::cache_key(const ForwardTable& table, const InverseTableSettings& settings) {
  std::string error;
  if (!settings.IsValid(&error)) throw std::invalid_argument("inverse table settings: " + error);
  WordHash h;
  h.add(kMagic, sizeof kMagic);
  h.add_value(kFormatVersion);
  h.add_value(table.key());
  h.add_value(table.channels());
  const auto n = table.nodes();
  h.add(n.data(), sizeof n);
  h.add(table.values().data(), table.values().size() * sizeof(float));
  for (double setting : {double(kBins), double(kMaxBranches), double(kMaxSeedsPerCell), double(kBranchIterations),
                         kSameBranch, kBranchChi2Margin, kMaxCondition, double(kFillReach[0]), double(kFillReach[1]),
                         double(kFillReach[2]), double(kFillReach[3]), double(kPresolveBlock[0]),
                         double(kPresolveBlock[1]), double(kPresolveBlock[2]), double(kPresolveBlock[3])})
    h.add_value(setting);
  h.add_value(settings.presolve_empty_cells);
  for (double q : settings.quantised_sigma()) h.add_value(q);  // the pre-solved fits' weights
  return h.h;
}

std::string InverseTable::file_name(std::uint64_t key) {
  char name[64];
  std::snprintf(name, sizeof name, "inverse_table_%016llx.bin", static_cast<unsigned long long>(key));
  return name;
}

void InverseTable::key_of(const float* values, float* key) const {
  float centred[4];
  for (int k = 0; k < key_dims_; ++k) centred[k] = inverse_table_key(values[k]) - key_mean_[k];
  for (int a = 0; a < key_dims_; ++a) {
    float sum = 0;
    for (int k = 0; k < key_dims_; ++k) sum += key_axes_[a * 4 + k] * centred[k];
    key[a] = sum;
  }
}

std::uint32_t InverseTable::cell_of(const float* measured) const {
  return cell_at(box_of(measured));
}

std::uint32_t InverseTable::box_of(const float* measured) const {
  float key[4];
  key_of(measured, key);
  std::uint32_t box = 0, stride = 1;
  for (int k = 0; k < key_dims_; ++k, stride *= kBins) {
    // Beyond the box's edge: the edge cell (its fill points at the nearest
    // branch); a non-finite key: no cell.
    const float position = (key[k] - key_min_[k]) * key_scale_[k];
    if (!std::isfinite(position)) return kNoCell;
    box += static_cast<std::uint32_t>(std::clamp(position, 0.0f, kBins - 1.0f)) * stride;
  }
  return box;
}

double InverseTable::filled_share() const {
  const auto filled = std::count_if(cell_index_.begin(), cell_index_.end(), [](std::uint32_t c) { return c != kNoCell; });
  return static_cast<double>(filled) / static_cast<double>(cell_index_.size());
}

namespace {

template <class T>
void write_array(std::ofstream& out, WordHash& h, const std::vector<T>& a) {
  const std::uint64_t n = a.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(a.data()), static_cast<std::streamsize>(n * sizeof(T)));
  h.add_value(n);
  h.add(a.data(), n * sizeof(T));
}

template <class T>
bool read_array(std::ifstream& in, WordHash& h, std::vector<T>& a, std::uint64_t max_size) {
  std::uint64_t n = 0;
  if (!in.read(reinterpret_cast<char*>(&n), sizeof n) || n > max_size) return false;
  a.resize(n);
  const auto bytes = static_cast<std::streamsize>(n * sizeof(T));
  if (!in.read(reinterpret_cast<char*>(a.data()), bytes) || in.gcount() != bytes) return false;
  h.add_value(n);
  h.add(a.data(), n * sizeof(T));
  return true;
}

}  // namespace

bool InverseTable::write(const std::filesystem::path& file) const {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  WordHash h;
  out.write(kMagic, 8);
  out.write(reinterpret_cast<const char*>(&kFormatVersion), sizeof kFormatVersion);
  out.write(reinterpret_cast<const char*>(&key_), sizeof key_);
  const std::int32_t dims = key_dims_, bins = kBins;
  out.write(reinterpret_cast<const char*>(&dims), sizeof dims);
  out.write(reinterpret_cast<const char*>(&bins), sizeof bins);
  out.write(reinterpret_cast<const char*>(key_mean_), sizeof key_mean_);
  out.write(reinterpret_cast<const char*>(key_axes_), sizeof key_axes_);
  out.write(reinterpret_cast<const char*>(key_min_), sizeof key_min_);
  out.write(reinterpret_cast<const char*>(key_scale_), sizeof key_scale_);
  h.add_value(key_), h.add_value(dims), h.add_value(bins), h.add(key_mean_, sizeof key_mean_),
      h.add(key_axes_, sizeof key_axes_), h.add(key_min_, sizeof key_min_), h.add(key_scale_, sizeof key_scale_);
  write_array(out, h, cell_index_);
  write_array(out, h, cells_);
  const std::uint64_t occupied = occupied_cells_;
  out.write(reinterpret_cast<const char*>(&occupied), sizeof occupied);
  h.add_value(occupied);
  write_array(out, h, bucket_nodes_);
  write_array(out, h, branches_);
  out.write(reinterpret_cast<const char*>(&h.h), sizeof h.h);
  return static_cast<bool>(out);
}

bool InverseTable::read(const std::filesystem::path& file, std::uint64_t key, std::string* why) {
  std::ifstream in(file, std::ios::binary);
  auto fail = [&](const char* reason) {
    *why = reason;
    return false;
  };
  char magic[8];
  std::uint32_t version = 0;
  std::int32_t dims = 0, bins = 0;
  if (!in.read(magic, 8) || std::memcmp(magic, kMagic, 8) != 0) return fail("not an inverse table file");
  if (!in.read(reinterpret_cast<char*>(&version), sizeof version) || version != kFormatVersion)
    return fail("another format version");
  WordHash h;
  if (!in.read(reinterpret_cast<char*>(&key_), sizeof key_) || key_ != key) return fail("another key");
  if (!in.read(reinterpret_cast<char*>(&dims), sizeof dims) || !in.read(reinterpret_cast<char*>(&bins), sizeof bins) ||
      dims < 1 || dims > 4 || bins != kBins)
    return fail("bad header");
  key_dims_ = dims;
  if (!in.read(reinterpret_cast<char*>(key_mean_), sizeof key_mean_) ||
      !in.read(reinterpret_cast<char*>(key_axes_), sizeof key_axes_) ||
      !in.read(reinterpret_cast<char*>(key_min_), sizeof key_min_) ||
      !in.read(reinterpret_cast<char*>(key_scale_), sizeof key_scale_))
    return fail("truncated header");
  h.add_value(key_), h.add_value(dims), h.add_value(bins), h.add(key_mean_, sizeof key_mean_),
      h.add(key_axes_, sizeof key_axes_), h.add(key_min_, sizeof key_min_), h.add(key_scale_, sizeof key_scale_);
  std::uint64_t box_cells = 1;
  for (int k = 0; k < dims; ++k) box_cells *= kBins;
  std::uint64_t occupied = 0;
  if (!read_array(in, h, cell_index_, box_cells) || cell_index_.size() != box_cells ||
      !read_array(in, h, cells_, box_cells) || !in.read(reinterpret_cast<char*>(&occupied), sizeof occupied) ||
      occupied > cells_.size())
    return fail("truncated or inconsistent sizes");
  h.add_value(occupied);
  if (!read_array(in, h, bucket_nodes_, 1ull << 32) ||
      !read_array(in, h, branches_, cells_.size() * (kMaxBranches + 2)))
    return fail("truncated or inconsistent sizes");
  std::uint64_t checksum = 0;
  if (!in.read(reinterpret_cast<char*>(&checksum), sizeof checksum) || in.peek() != std::char_traits<char>::eof())
    return fail("truncated or trailing bytes");
  if (checksum != h.h) return fail("checksum mismatch");
  occupied_cells_ = static_cast<std::size_t>(occupied);
  // Indices in range (a file written by another build with the same key cannot point outside its arrays).
  for (std::uint32_t c : cell_index_)
    if (c != kNoCell && c >= cells_.size()) return fail("cell index out of range");
  for (const Cell& c : cells_)
    if (std::uint64_t(c.bucket_begin) + c.bucket_count > bucket_nodes_.size() ||
        std::uint64_t(c.branch_begin) + c.branch_count > branches_.size() || c.branch_count > kMaxBranches ||
        (c.presolved_branch != kNoCell && c.presolved_branch >= branches_.size()) ||
        (c.slice_branch != kNoCell && c.slice_branch >= branches_.size()))
      return fail("cell range out of range");
  return true;
}

std::shared_ptr<const InverseTable> InverseTable::load_or_build(std::shared_ptr<const ForwardTable> table,
                                                                const std::filesystem::path& cache_dir, bool* rebuilt,
                                                                std::string* warning, int threads,
                                                                const InverseTableSettings& settings) {
  if (!table || table->values().empty()) throw std::invalid_argument("inverse table: empty forward table");
  if (warning) warning->clear();
  const std::uint64_t key = cache_key(*table, settings);
  const std::filesystem::path file = cache_dir / file_name(key);
  // One table per key and process while anyone holds it; the lock also keeps
  // two threads of one process from building the same table twice.
  static std::mutex registry_mutex;
  static std::map<std::pair<std::uint64_t, std::string>, std::weak_ptr<const InverseTable>> registry;
  std::lock_guard lock(registry_mutex);
  auto& slot = registry[{key, file.string()}];
  if (auto shared = slot.lock()) {
    if (rebuilt) *rebuilt = false;
    return shared;
  }
  for (auto it = registry.begin(); it != registry.end();) it = it->second.expired() && &it->second != &slot ? registry.erase(it) : std::next(it);

  std::error_code ec;
  if (std::filesystem::exists(file, ec)) {
    auto loaded = std::make_shared<InverseTable>();
    std::string why;
    if (loaded->read(file, key, &why) && loaded->bucket_nodes_.size() == table->grid().node_count()) {
      if (rebuilt) *rebuilt = false;
      slot = loaded;
      return loaded;
    }
    if (why.empty()) why = "bucket size does not match the table";
    const std::string message = "inverse table cache " + file.string() + " is unusable (" + why + "); rebuilding it";
    if (warning) *warning = message;
    std::fprintf(stderr, "warning: %s\n", message.c_str());
  }
  auto built = std::make_shared<InverseTable>(build(table, threads, settings));
  if (rebuilt) *rebuilt = true;
  slot = built;
  std::filesystem::create_directories(cache_dir, ec);
  const std::filesystem::path temporary =
      cache_dir / (file_name(key) + ".tmp" + std::to_string(static_cast<long long>(::getpid())));
  if (built->write(temporary)) {
    std::filesystem::rename(temporary, file, ec);  // a cache that cannot be written is not an error
    if (ec) std::filesystem::remove(temporary, ec);
  } else {
    std::filesystem::remove(temporary, ec);
  }
  return built;
}

}  // namespace chromo::estimation
