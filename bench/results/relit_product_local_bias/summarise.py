#!/usr/bin/env python3
"""Spread tables and the chart of bench/results/relit_product_local_bias/ (relit_product_bench
--local-bias runs at several caps): skin flagged vs ink/marker caught per rule, mean [min, max]
over folds x seeds. Usage: summarise.py [results dir]; writes local_bias_summary.txt,
local_bias_flags.dat/.gp/.png."""
import csv, os, subprocess, sys

root = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
rules = []  # (rule name, rows)
for cap in ("cap4", "cap2", "cap1"):
    path = os.path.join(root, cap, "relit_product.csv")
    if not os.path.exists(path):
        continue
    rows = list(csv.DictReader(open(path)))
    if cap == "cap4":
        rules.append(("learned (off)", [r for r in rows if r["local_bias"] == "0"]))
    rules.append(("local bias, cap " + cap[3:], [r for r in rows if r["local_bias"] == "1"]))

def spread(vals):
    return sum(vals) / len(vals), min(vals), max(vals)

out = []
dat = []
for plan in ("six-leds", "method"):
    for scene in ("real", "model"):
        out.append(f"\n{plan}, {scene} skin (mean [min, max] over folds x seeds)")
        out.append(f"{'rule':22} {'n':>3} {'skin flagged %':>24} {'per pixel %':>22} {'code 7 %':>22} {'ink %':>22} {'marker %':>22} {'relit model+disc':>24} {'006 skin %':>10} {'006 ink %':>10}")
        for name, rows in rules:
            sel = [r for r in rows if r["plan"] == plan and r["scene"] == scene]
            if not sel:
                continue
            f = lambda k, s=100: spread([s * float(r[k]) for r in sel])
            fl, px, nb, ink, mk, de = f("skin_flagged"), f("skin_pixel_flagged"), f("skin_neighbourhood_flagged"), f("ink_caught"), f("marker_caught"), f("relit_model_disc", 1)
            s6 = [100 * float(r["skin_006_flagged"]) for r in sel if float(r["skin_006_flagged"]) >= 0]
            i6 = [100 * float(r["ink_006_caught"]) for r in sel if float(r["ink_006_caught"]) >= 0]
            m = lambda v: "%.1f" % (sum(v) / len(v)) if v else "-"
            fmt = lambda t, d=2: f"{t[0]:.{d}f} [{t[1]:.{d}f}, {t[2]:.{d}f}]"
            out.append(f"{name:22} {len(sel):>3} {fmt(fl):>24} {fmt(px):>22} {fmt(nb):>22} {fmt(ink,1):>22} {fmt(mk,1):>22} {fmt(de,3):>24} {m(s6):>10} {m(i6):>10}")
            dat.append((f"{plan} {scene}", name, fl[0], min(ink[0], mk[0]), ink[1]))
text = "\n".join(out)
print(text)
open(os.path.join(root, "local_bias_summary.txt"), "w").write(text + "\n")
# Chart: one point per (plan, scene, rule): x = skin flagged (mean), y = the worst run's ink caught.
with open(os.path.join(root, "local_bias_flags.dat"), "w") as d:
    for i, (name, _) in enumerate(rules):
        d.write(f"# {name}\n")
        for cfg, rule, fl, caught, ink_lo in dat:
            if rule == name:
                d.write(f'{fl:.3f} {ink_lo:.2f} "{cfg}"\n')
        d.write("\n\n")
plot = ", ".join(f"'{root}/local_bias_flags.dat' index {i} using 1:2 with points pt {5 + 2 * i} ps 2 title '{n}', '' index {i} using 1:2:3 with labels offset 0,1 font ',8' notitle" for i, (n, _) in enumerate(rules))
gp = f"""set terminal pngcairo size 1000,600 font 'DejaVu Sans,10'
set output '{root}/local_bias_flags.png'
set title 'relit_product_bench: skin flagged (mean over folds x seeds) vs ink caught (worst fold x seed), per flag rule' noenhanced
set xlabel 'skin flagged, % (mean)'
set ylabel 'ink caught, % (worst run)'
set grid
set key outside right
set yrange [0:105]
set arrow from graph 0, first 95 to graph 1, first 95 nohead dt 2
plot {plot}
"""
open(os.path.join(root, "local_bias_flags.gp"), "w").write(gp)
subprocess.run(["gnuplot", os.path.join(root, "local_bias_flags.gp")], check=False)
