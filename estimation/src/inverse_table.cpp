// InverseTable (inverse_table.hpp): its settings, key space and lookup, and
// its cache file. The build is in inverse_table_build.cpp.
#include "chromo/estimation/inverse_table.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <stdexcept>
#include <system_error>

#include "chromo/files/binary_cache.hpp"
#include "chromo/files/fnv1a.hpp"
#include "inverse_table_internal.hpp"

namespace chromo::estimation {

using namespace detail;

namespace {
constexpr int kMaxKeyDimsForKey = InverseTable::kMaxKeyDims;
}  // namespace

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
  for (double s : channel_relative_sigma)
    if (!(s > 0 && std::isfinite(s))) {
      if (error) *error = "channel_relative_sigma must be finite and > 0";
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
  if (set.size() > 4 && channel_relative_sigma.empty())
    for (const MeasurementChannel& c : set.channels) out.channel_relative_sigma.push_back(std::sqrt(c.noise.variance(0.2)) / 0.2);
  return out;
}

std::vector<double> InverseTableSettings::quantised_channel_sigma(int channels) const {
  std::vector<double> q(std::max(channels, 0), 1.0);
  if (static_cast<int>(channel_relative_sigma.size()) != channels || channels == 0) return q;
  const double smallest = *std::min_element(channel_relative_sigma.begin(), channel_relative_sigma.end());
  if (!(smallest > 0)) return q;
  for (int c = 0; c < channels; ++c) q[c] = std::exp2(std::round(2 * std::log2(channel_relative_sigma[c] / smallest)) / 2);
  return q;
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
  files::Fnv1a h;
  h.add(kCacheFormat.magic);
  h.add(kCacheFormat.version);
  h.add(table.key());
  h.add(table.channels());
  const auto n = table.nodes();
  h.add(n.data(), sizeof n);
  h.add(table.values().data(), table.values().size() * sizeof(float));
  for (double setting : {double(kBins), double(kMaxBranches), double(kMaxSeedsPerCell), double(kBranchIterations),
                         kSameBranch, kBranchChi2Margin, kMaxCondition, double(kFillReach[0]), double(kFillReach[1]),
                         double(kFillReach[2]), double(kFillReach[3]), double(kPresolveBlock[0]),
                         double(kPresolveBlock[1]), double(kPresolveBlock[2]), double(kPresolveBlock[3])})
    h.add(setting);
  h.add(settings.presolve_empty_cells);
  for (double q : settings.quantised_sigma()) h.add(q);  // the pre-solved fits' weights
  if (table.channels() > kMaxKeyDimsForKey)
    for (double q : settings.quantised_channel_sigma(table.channels())) h.add(q);  // the key's whitening
  return h.h;
}

std::string InverseTable::file_name(std::uint64_t key) { return files::cache_file_name("inverse_table", key); }

void InverseTable::key_of(const float* values, float* key) const {
  const int channels = key_channels_;
  if (channels <= kMaxKeyDims) {  // square rotation, no whitening: the 4-channel tables' key as before
    float centred[kMaxKeyDims];
    for (int k = 0; k < channels; ++k) centred[k] = inverse_table_key(values[k]) - key_mean_[k];
    for (int a = 0; a < key_dims_; ++a) {
      float sum = 0;
      for (int k = 0; k < channels; ++k) sum += key_axes_[a * channels + k] * centred[k];
      key[a] = sum;
    }
    return;
  }
  for (int a = 0; a < key_dims_; ++a) key[a] = 0;
  for (int c = 0; c < channels; ++c) {
    const float centred = inverse_table_key(values[c]) * key_whiten_[c] - key_mean_[c];
    for (int a = 0; a < key_dims_; ++a) key[a] += key_axes_[a * channels + c] * centred;
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

// The cache file's payload (files/binary_cache.hpp holds magic, version,
// key, length and checksum): the key space's dimensions and bins, the
// channel count, the captured variance, the per-channel whitening and mean,
// the axes (dims × channels), minimum and scale, the cell index, the cells, the occupied cells'
// count, the bucket nodes and the branches (each array: uint64 count, then
// the elements).
std::vector<std::uint8_t> InverseTable::encode() const {
  files::CacheWriter out;
  out.reserve(3 * sizeof(std::int32_t) + sizeof(double) + 3 * sizeof(std::uint64_t) +
              (key_whiten_.size() + key_mean_.size() + key_axes_.size()) * sizeof(float) + sizeof key_min_ + sizeof key_scale_ +
              5 * sizeof(std::uint64_t) + cell_index_.size() * sizeof(std::uint32_t) + cells_.size() * sizeof(Cell) +
              bucket_nodes_.size() * sizeof(std::uint32_t) + branches_.size() * sizeof(Branch));
  out.put<std::int32_t>(key_dims_);
  out.put<std::int32_t>(kBins);
  out.put<std::int32_t>(key_channels_);
  out.put<double>(captured_variance_);
  out.put_vector(key_whiten_), out.put_vector(key_mean_), out.put_vector(key_axes_);
  out.put(key_min_), out.put(key_scale_);
  out.put_vector(cell_index_);
  out.put_vector(cells_);
  out.put<std::uint64_t>(occupied_cells_);
  out.put_vector(bucket_nodes_);
  out.put_vector(branches_);
  return out.take_bytes();
}

bool InverseTable::decode(std::span<const std::uint8_t> payload, std::uint64_t key, std::string* why) {
  auto fail = [&](const char* reason) {
    *why = reason;
    return false;
  };
  files::CacheReader in(payload);
  key_ = key;
  const auto dims = in.get<std::int32_t>(), bins = in.get<std::int32_t>();
  const auto channels = in.get<std::int32_t>();
  if (!in.ok() || dims < 1 || dims > kMaxKeyDims || bins != kBins || channels < dims || channels > 1 << 16)
    return fail("bad header");
  key_dims_ = dims, key_channels_ = channels;
  captured_variance_ = in.get<double>();
  key_whiten_ = in.get_vector<float>(channels), key_mean_ = in.get_vector<float>(channels);
  key_axes_ = in.get_vector<float>(std::uint64_t(dims) * channels);
  in.get_bytes(key_min_, sizeof key_min_), in.get_bytes(key_scale_, sizeof key_scale_);
  if (!in.ok()) return fail("truncated header");
  if (key_whiten_.size() != std::size_t(channels) || key_mean_.size() != std::size_t(channels) ||
      key_axes_.size() != std::size_t(dims) * channels)
    return fail("key space of the wrong size");
  std::uint64_t box_cells = 1;
  for (int k = 0; k < dims; ++k) box_cells *= kBins;
  cell_index_ = in.get_vector<std::uint32_t>(box_cells);
  cells_ = in.get_vector<Cell>(box_cells);
  const auto occupied = in.get<std::uint64_t>();
  if (!in.ok() || cell_index_.size() != box_cells || occupied > cells_.size())
    return fail("truncated or inconsistent sizes");
  bucket_nodes_ = in.get_vector<std::uint32_t>(1ull << 32);
  branches_ = in.get_vector<Branch>(cells_.size() * (kMaxBranches + 2));
  if (!in.ok()) return fail("truncated or inconsistent sizes");
  if (!in.at_end()) return fail("trailing bytes");
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
    const auto payload = files::read_cache(file, kCacheFormat, key, &why);
    if (payload && loaded->decode(*payload, key, &why) && loaded->bucket_nodes_.size() == table->grid().node_count() &&
        loaded->key_channels_ == table->channels()) {
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
  try {
    files::write_cache(file, kCacheFormat, key, built->encode());
  } catch (const std::exception&) {
    // A cache that cannot be written is not an error: the table is in memory.
  }
  return built;
}

}  // namespace chromo::estimation
