#!/usr/bin/env python3
"""Per-fold skin flagged (mean of the seeds) and the spread over folds x seeds
for each relit_product_bench run folder given (its relit_product.csv)."""
import csv, sys, statistics
from collections import defaultdict

for folder in sys.argv[1:]:
    rows = list(csv.DictReader(open(f"{folder}/relit_product.csv")))
    by = defaultdict(list)
    for r in rows:
        by[(r["plan"], r["scene"])].append(r)
    print(f"== {folder}")
    for (plan, scene), rs in by.items():
        folds = defaultdict(list)
        for r in rs:
            folds[int(r["fold"])].append(100 * float(r["skin_flagged"]))
        per_fold = " ".join(f"f{f} {statistics.mean(v):5.2f}" for f, v in sorted(folds.items()))
        all_ = [100 * float(r["skin_flagged"]) for r in rs]
        px = statistics.mean(100 * float(r["skin_pixel_flagged"]) for r in rs)
        c7 = statistics.mean(100 * float(r["skin_neighbourhood_flagged"]) for r in rs)
        ink = [100 * float(r["ink_caught"]) for r in rs]
        mk = [100 * float(r["marker_caught"]) for r in rs]
        s006 = [100 * float(r["skin_006_flagged"]) for r in rs if float(r["skin_006_flagged"]) >= 0]
        print(f"{plan:9s} {scene:5s} skin {statistics.mean(all_):5.2f} [{min(all_):.2f}, {max(all_):.2f}] "
              f"(per pixel {px:.2f}, code 7 {c7:.2f}) | {per_fold} | ink {statistics.mean(ink):.1f} [{min(ink):.1f}] "
              f"marker {statistics.mean(mk):.1f} [{min(mk):.1f}]" + (f" | 006 skin {statistics.mean(s006):.1f}" if s006 else ""))
