#pragma once
// A figure's spread over a bench's seeds: mean, min and max of get(row) over
// the rows (one per seed), the way the benches report accuracy claims.

#include <algorithm>
#include <vector>

namespace chromo::bench {

struct Spread {
  double mean = 0, lo = 0, hi = 0;
};

// rows must not be empty.
template <class Row, class Get>
Spread spread(const std::vector<Row>& rows, Get get) {
  Spread s{0, get(rows.front()), get(rows.front())};
  for (const Row& r : rows) s.mean += get(r) / rows.size(), s.lo = std::min(s.lo, get(r)), s.hi = std::max(s.hi, get(r));
  return s;
}

}  // namespace chromo::bench
