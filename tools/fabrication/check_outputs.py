#!/usr/bin/env python3
"""Independent readers for host-tool's fabrication outputs (run by .ci/fabrication-check.sh).

  check_outputs.py dxf FILE.dxf --fold FILE.fold --edge-mm L --seam-mm S
  check_outputs.py panel FILE.3mf --stl-dir DIR
  check_outputs.py mesh FILE [FILE ...]          (STL/OBJ/GLB: watertight, consistent, volume)
  check_outputs.py kit FILE.json --hinges H --screws S
  check_outputs.py nest DIR --sheet WxH --margin-mm M --spacing-mm S --kerf-mm K --hole-mm D
                   --n N --layers L --kit KIT.json   (cut sheets: ezdxf + shapely)
  check_outputs.py tiles FULL.svg PAGE.svg [...]   (paper tiles: 1:1, marks align, lines = the full pattern)
  check_outputs.py parts REPORT.json [--tendon-radius-mm R] [--formats stl|both]  (STL + 3MF parts: trimesh)
  check_outputs.py bom FILE.csv --parts REPORT.json [--expect PART ...]  (printed parts and filament in a BOM)
  check_outputs.py legend FILE.svg [...] [--expect legend|none] [--footer-mm F]  (legend rendered inside its box)
  check_outputs.py glb FILE.glb [...] [--expect-red yes|no] (GLB read with numpy alone)
  check_outputs.py render FILE OUT.png [--title T] (a matplotlib projection of a 3D file)

Each check prints one line; the exit code is 0 only when all pass.
"""
import argparse
import json
import math
import sys
import xml.etree.ElementTree as ET
import zipfile

FAILED = 0


def check(ok, what):
    global FAILED
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        FAILED += 1


def cmd_dxf(a):
    import ezdxf

    doc = ezdxf.readfile(a.file)
    fold = json.load(open(a.fold))
    check(doc.header.get("$INSUNITS") == 4, f"$INSUNITS = 4 (mm), got {doc.header.get('$INSUNITS')}")
    names = {layer.dxf.name for layer in doc.layers}
    for want in ["MOUNTAIN", "VALLEY", "CUT", "BOUNDARY", "VIRTUAL"]:
        check(want in names, f"layer {want} present")
    msp = doc.modelspace()
    lines = list(msp)
    check(all(e.dxftype() == "LINE" for e in lines), f"{len(lines)} entities, all LINE")
    by = {}
    for e in lines:
        by.setdefault(e.dxf.layer, []).append(e)
    assign = fold["edges_assignment"]
    count = {k: assign.count(k) for k in "MVBU"}
    tab = 3 if a.seam_mm > 0 else 0
    check(len(by.get("MOUNTAIN", [])) == count["M"], f"MOUNTAIN lines = FOLD M edges ({count['M']})")
    check(len(by.get("VALLEY", [])) == count["V"], f"VALLEY lines = FOLD V edges ({count['V']})")
    check(len(by.get("CUT", [])) == tab, f"CUT lines = seam tab outline ({tab})")
    check(len(by.get("BOUNDARY", [])) + len(by.get("VIRTUAL", [])) == count["B"] + count["U"],
          "BOUNDARY + VIRTUAL lines = FOLD B + U edges")
    length = lambda e: math.dist((e.dxf.start.x, e.dxf.start.y), (e.dxf.end.x, e.dxf.end.y))
    half = a.edge_mm / 2
    check(all(abs(length(e) - half) < 1e-6 for e in by.get("VALLEY", [])),
          f"every valley line is half a valley fold, l/2 = {half} mm")
    # Mountain lengths a = l / (2 cos β) for the β of the layers, recovered from the FOLD file.
    v = fold["vertices_coords"]
    mountains = sorted({round(math.dist(v[i], v[j]), 6)
                        for (i, j), s in zip(fold["edges_vertices"], assign) if s == "M"})
    check(all(any(abs(length(e) - m) < 1e-6 for m in mountains) for e in by.get("MOUNTAIN", [])),
          f"mountain lines have the FOLD pattern's lengths {mountains} mm")
    betas = [math.degrees(math.acos(a.edge_mm / (2 * m))) for m in mountains]
    print("info mountain lengths imply beta =", [round(b, 4) for b in betas], "deg")
    xs = [p for e in lines for p in (e.dxf.start[0], e.dxf.end[0])]
    ys = [p for e in lines for p in (e.dxf.start[1], e.dxf.end[1])]
    width = max(xs) - min(xs)
    fx = [p[0] for p in v]
    check(abs(width - (max(fx) - min(fx) + a.seam_mm)) < 1e-6,
          f"sheet width {width:.3f} mm = pattern + seam allowance")
    fy = [p[1] for p in v]
    check(abs((max(ys) - min(ys)) - (max(fy) - min(fy))) < 1e-6, f"sheet height {max(ys) - min(ys):.3f} mm")


def mesh_checks(name, m):
    import trimesh  # noqa: F401

    check(m.is_watertight, f"{name}: watertight ({len(m.faces)} triangles)")
    check(m.is_winding_consistent, f"{name}: consistent winding (oriented manifold)")
    check(m.volume > 0, f"{name}: positive volume {m.volume:.3f}")
    bodies = m.split(only_watertight=False)
    check(all(b.is_watertight and b.volume > 0 for b in bodies), f"{name}: {len(bodies)} closed bodies, each of positive volume")
    return bodies


def footprints_disjoint(name, bodies):
    from shapely.geometry import MultiPoint

    polys = [MultiPoint([tuple(p[:2]) for p in b.vertices]).convex_hull for b in bodies]
    worst = 0.0
    for i in range(len(polys)):
        for j in range(i + 1, len(polys)):
            if polys[i].intersects(polys[j]):
                worst = max(worst, polys[i].intersection(polys[j]).area)
    check(worst < 1e-9, f"{name}: no two facets overlap (largest overlap {worst:.2e} mm²)")
    gaps = []
    for i in range(len(polys)):
        gaps.append(min(polys[i].distance(polys[j]) for j in range(len(polys)) if j != i))
    return min(gaps) if gaps else None


def cmd_panel(a):
    import trimesh

    z = zipfile.ZipFile(a.file)
    names = z.namelist()
    check("3D/3dmodel.model" in names and "[Content_Types].xml" in names and "_rels/.rels" in names,
          f"3MF package parts {sorted(names)}")
    root = ET.fromstring(z.read("3D/3dmodel.model"))
    ns = {"c": "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"}
    check(root.get("unit") == "millimeter", "unit millimeter")
    meta = {m.get("name"): (m.text or "") for m in root.findall("c:metadata", ns)}
    for k in ["Title", "Application", "ys:base_material", "ys:facet_material", "ys:base_mm", "ys:facet_mm", "ys:gap_mm", "ys:edge_mm"]:
        check(k in meta, f"metadata {k} = {meta.get(k)!r}")
    mats = root.findall("c:resources/c:basematerials/c:base", ns)
    check(len(mats) == 2, f"two base materials {[m.get('name') for m in mats]}")
    objs = root.findall("c:resources/c:object", ns)
    check(len(objs) == 2 and sorted(o.get("pindex") for o in objs) == ["0", "1"],
          f"two objects, one per material: {[o.get('name') for o in objs]}")
    scene = trimesh.load(a.file, force="scene")
    geoms = list(scene.geometry.items())
    check(len(geoms) == 2, f"trimesh reads {len(geoms)} objects")
    base_mm, facet_mm, gap_mm = float(meta.get("ys:base_mm", "nan")), float(meta.get("ys:facet_mm", "nan")), meta.get("ys:gap_mm", "")
    for gname, g in geoms:
        bodies = mesh_checks(f"3mf {gname}", g)
        zmin, zmax = g.bounds[0][2], g.bounds[1][2]
        if len(bodies) == 1:
            check(abs(zmin) < 1e-9 and abs(zmax - base_mm) < 1e-9, f"base sheet z in [0, {base_mm}] mm")
        else:
            check(abs(zmin - base_mm) < 1e-9 and abs(zmax - base_mm - facet_mm) < 1e-9,
                  f"facets z in [{base_mm}, {base_mm + facet_mm}] mm, on the base")
            gap = footprints_disjoint("3mf facets", bodies)
            gaps = [float(x) for x in gap_mm.split(",")] if gap_mm else []
            check(gap is not None and gaps and gap > min(gaps) - 1e-6,
                  f"smallest distance between neighbouring facets {gap:.4f} mm ≥ gap {min(gaps) if gaps else '?'} mm")
    if a.stl_dir:
        import glob
        import os

        files = sorted(glob.glob(os.path.join(a.stl_dir, "*.stl")))
        check(len(files) == 2, f"two STL files {[os.path.basename(f) for f in files]}")
        vol3 = sorted(g.volume for _, g in geoms)
        vols = []
        for f in files:
            m = trimesh.load(f, force="mesh")
            mesh_checks(f"stl {os.path.basename(f)}", m)
            vols.append(m.volume)
        check(all(abs(x - y) < 1e-6 * max(1, y) for x, y in zip(sorted(vols), vol3)),
              f"STL volumes {sorted(round(v, 3) for v in vols)} = 3MF volumes")


def cmd_mesh(a):
    import trimesh

    for f in a.files:
        m = trimesh.load(f, force="mesh")
        check(len(m.faces) > 0, f"{f}: {len(m.faces)} triangles, bounds {m.bounds.round(3).tolist()}")
        if a.closed:
            mesh_checks(f, m)


def cmd_parts(a):
    """The printable parts of `pattern --parts DIR -j`: every STL closed, consistently wound,
    one body of positive volume (the volume host-tool reports within 0.1 %), and a circle of
    vertices at every hole it reports; tendon holes at the tendon radius. Every 3MF beside it
    read by trimesh: watertight, consistently wound, one body, its volume the STL's within
    1e-6 relative; its model in millimetres with one object and one build item, its metadata
    naming the part, the quantity and the material host-tool reports."""
    import json
    import math
    import os

    import numpy as np
    import trimesh

    report = json.load(open(a.report))
    entries = [f for f in report["files"] if f["flag"] == "--parts"]
    files = [f for f in entries if f["format"] == "stl"]
    threemfs = {f["part"]: f for f in entries if f["format"] == "3mf"}
    check(len(files) == len(a.expect), f"{len(files)} parts reported ({', '.join(f['part'] for f in files)})")
    check(sorted(f["part"] for f in files) == sorted(a.expect), f"parts are {sorted(a.expect)}")
    if a.formats == "both":
        check(sorted(threemfs) == sorted(a.expect), f"a 3MF beside every STL ({len(threemfs)})")
    for f in files:
        path = f["path"]
        m = trimesh.load(path, force="mesh")
        check(len(m.faces) == f["triangles"], f"{path}: {len(m.faces)} triangles as reported")
        bodies = mesh_checks(path, m)
        check(len(bodies) == 1, f"{path}: one body")
        rel = abs(m.volume - f["volume_mm3"]) / f["volume_mm3"]
        check(rel < 1e-3, f"{path}: volume {m.volume:.1f} mm^3 = the reported {f['volume_mm3']:.1f} ({100 * rel:.3f} %)")
        v = np.asarray(m.vertices)
        for h in f["holes"]:
            c, ax = np.array(h["centre_mm"]), np.array(h["axis"])
            d = v - c
            along = d @ ax
            radial = np.sqrt(np.maximum((d * d).sum(axis=1) - along**2, 0))
            # STL stores float32: 1e-3 mm.
            on = np.sum((np.abs(along) < 1e-3) & (np.abs(radial - h["diameter_mm"] / 2) < 1e-3))
            check(on >= 8, f"{path}: {h['role']} hole d = {h['diameter_mm']} mm at {np.round(c, 3).tolist()} ({on} vertices on its rim)")
            if h["role"] == "tendon" and a.tendon_radius_mm is not None:
                r = math.hypot(c[0], c[1])
                check(abs(r - a.tendon_radius_mm) < 0.01, f"{path}: tendon hole at r = {r:.3f} mm (expected {a.tendon_radius_mm})")
        t = threemfs.get(f["part"])
        if t is None:
            continue
        tpath = t["path"]
        check(os.path.splitext(tpath)[0] == os.path.splitext(path)[0], f"{tpath}: beside {os.path.basename(path)}")
        g = trimesh.load(tpath, force="mesh")
        gb = mesh_checks(tpath, g)
        check(len(gb) == 1 and len(g.faces) == len(m.faces), f"{tpath}: one body, {len(g.faces)} triangles like the STL")
        rel = abs(g.volume - m.volume) / m.volume
        check(rel < 1e-6, f"{tpath}: volume {g.volume:.3f} mm^3 = the STL's {m.volume:.3f} (relative {rel:.1e} < 1e-6)")
        root = ET.fromstring(zipfile.ZipFile(tpath).read("3D/3dmodel.model"))
        ns = {"c": "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"}
        meta = {e.get("name"): (e.text or "") for e in root.findall("c:metadata", ns)}
        check(root.get("unit") == "millimeter", f"{tpath}: unit millimeter")
        check(len(root.findall("c:resources/c:object", ns)) == 1 and len(root.findall("c:build/c:item", ns)) == 1,
              f"{tpath}: one object, one build item")
        mats = [b.get("name") for b in root.findall("c:resources/c:basematerials/c:base", ns)]
        check(mats == [f["material"]], f"{tpath}: base material {mats}")
        want = {"ys:part": f["part"], "ys:quantity": str(f["quantity"]), "ys:material": f["material"]}
        check(all(meta.get(k) == v for k, v in want.items()),
              f"{tpath}: metadata part {meta.get('ys:part')!r}, quantity {meta.get('ys:quantity')}, material {meta.get('ys:material')!r}")
        mass = float(meta.get("ys:mass_g", "nan"))
        dens = float(meta.get("ys:density_g_per_cm3", "nan"))
        check(abs(mass - g.volume / 1000 * dens) <= 0.005 + 1e-9,
              f"{tpath}: mass {mass} g = volume x {dens} g/cm^3")


def cmd_bom(a):
    """A bill of materials against the parts' report (`pattern --parts DIR -j`): every printed
    part the BOM names is one of the report's parts with its quantity, and each filament row's
    grams are the sum of quantity x trimesh's volume of the STL x the report's density, within
    0.05 g (the BOM rounds to 0.1 g)."""
    import csv
    import re

    import trimesh

    rows = list(csv.DictReader(open(a.file, newline="")))
    check(rows and list(rows[0].keys()) == ["section", "part", "quantity", "unit", "specification"], f"{a.file}: header")
    report = json.load(open(a.parts))
    parts = {f["part"]: f for f in report["files"] if f["flag"] == "--parts" and f["format"] == "stl"}
    named = []
    for r in rows:
        m = re.search(r"\(([a-z-]+)\.stl / \.3mf\)$", r["part"])
        if r["section"] == "printed" and m:
            f = parts.get(m.group(1))
            check(f is not None and float(r["quantity"]) == f["quantity"],
                  f"{a.file}: {m.group(1)} x {r['quantity']} (the report: {f and f['quantity']})")
            if f is not None:
                named.append(f)
    check(sorted(f["part"] for f in named) == sorted(a.expect), f"{a.file}: printed parts {sorted(f['part'] for f in named)}")
    volumes = {f["part"]: trimesh.load(f["path"], force="mesh").volume for f in named}
    for material in sorted({f["material"] for f in named}):
        want = sum(f["quantity"] * volumes[f["part"]] / 1000 * f["density_g_per_cm3"] for f in named if f["material"] == material)
        row = [r for r in rows if r["part"] == f"{material} filament (printed parts)"]
        got = float(row[0]["quantity"]) if row else float("nan")
        check(row and row[0]["unit"] == "g" and abs(got - want) <= 0.05 + 1e-9,
              f"{a.file}: {material} filament {got} g = sum of quantity x STL volume x density {want:.2f} g")
    for r in rows:
        if r["part"] == "disc magnet":
            want = sum(f["quantity"] * sum(1 for h in f["holes"] if h["role"] == "magnet") for f in named)
            check(float(r["quantity"]) == want, f"{a.file}: {r['quantity']} magnets = the parts' {want} magnet pockets")


def cmd_legend(a):
    """The legend of an SVG page (`--svg` or a `--page` tile): rendered alone with rsvg-convert,
    every drawn pixel lies inside the box the SVG declares (`data-box` of `<g id="legend">`),
    the box is inside the page's printable area, and no crease line of the page crosses it."""
    import os
    import subprocess
    import tempfile

    import numpy as np
    from matplotlib.image import imread

    ns = "{http://www.w3.org/2000/svg}"
    for path in a.files:
        name = os.path.basename(path)
        tree = ET.parse(path)
        root = tree.getroot()
        vb = [float(x) for x in root.get("viewBox").split()]
        legend = [g for g in root.iter(ns + "g") if g.get("id") == "legend"]
        if a.expect == "none":
            check(not legend, f"{name}: no legend")
            continue
        check(len(legend) == 1, f"{name}: one legend")
        if not legend:
            continue
        x, y, w, h = (float(v) for v in legend[0].get("data-box").split())
        m = a.margin_mm
        check(x >= m - 1e-3 and y >= m - 1e-3 and x + w <= vb[2] - m + 1e-3 and y + h <= vb[3] - m - a.footer_mm + 1e-3,
              f"{name}: legend box {x:.1f} {y:.1f} {w:.1f} x {h:.1f} inside the {vb[2]:.1f} x {vb[3]:.1f} page's printable area")

        def crosses(p, q):
            # Liang-Barsky against the box.
            dx, dy = q[0] - p[0], q[1] - p[1]
            t0, t1 = 0.0, 1.0
            for pp, qq in ((-dx, p[0] - x), (dx, x + w - p[0]), (-dy, p[1] - y), (dy, y + h - p[1])):
                if pp == 0:
                    if qq < 0:
                        return False
                else:
                    t = qq / pp
                    if pp < 0:
                        t0 = max(t0, t)
                    else:
                        t1 = min(t1, t)
            return t0 <= t1

        lines = [(g.get("id"), ln) for g in root.iter(ns + "g") if g.get("id") in ("mountain", "valley", "boundary", "cut", "virtual") for ln in g.iter(ns + "line")]
        bad = [k for k, ln in lines if crosses((float(ln.get("x1")), float(ln.get("y1"))), (float(ln.get("x2")), float(ln.get("y2"))))]
        check(lines and not bad, f"{name}: none of {len(lines)} crease lines crosses the legend ({len(bad)} do)")
        # Only the legend and its scale bar, rendered at 10 px/mm.
        for parent in list(root.iter()):
            for child in list(parent):
                if child.tag == ns + "g" and child.get("id") not in ("legend", "annotation"):
                    parent.remove(child)
                elif child.tag == ns + "rect":
                    parent.remove(child)
        with tempfile.TemporaryDirectory() as tmp:
            svg, png = os.path.join(tmp, "l.svg"), os.path.join(tmp, "l.png")
            tree.write(svg)
            px = 10.0
            subprocess.run(["rsvg-convert", "-w", str(int(round(vb[2] * px))), "-b", "white", svg, "-o", png], check=True)
            img = imread(png)[:, :, :3]
        scale = img.shape[1] / vb[2]
        ink = np.argwhere(img.min(axis=2) < 0.9)
        if len(ink) == 0:
            check(False, f"{name}: the legend renders")
            continue
        (r0, c0), (r1, c1) = ink.min(axis=0), ink.max(axis=0)
        got = (c0 / scale, r0 / scale, (c1 + 1) / scale, (r1 + 1) / scale)
        # The scale bar's 0.5 mm stroke may stand 0.25 mm outside the box; one pixel of rounding.
        tol = 0.25 + 1 / scale
        check(got[0] >= x - tol and got[1] >= y - tol and got[2] <= x + w + tol and got[3] <= y + h + tol,
              f"{name}: rendered legend {got[0]:.1f}..{got[2]:.1f} x {got[1]:.1f}..{got[3]:.1f} mm inside its box {x:.1f}..{x + w:.1f} x {y:.1f}..{y + h:.1f}")


def cmd_kit(a):
    kit = json.load(open(a.file))
    check(kit["hinges"] == a.hinges, f"hinges {kit['hinges']} (expected {a.hinges})")
    check(kit["screws"] == a.screws, f"screws {kit['screws']} (expected {a.screws})")
    placed = len(kit["hinge_positions"])
    check(placed == kit["hinges"], f"{placed} hinge positions listed")
    facets = sum(f["count"] for f in kit["facets"])
    check(facets == kit["facet_count"], f"{facets} facets in the cut list")


def cmd_nest(a):
    """The cut sheets read back with ezdxf alone, judged with shapely: every facet once, inside
    the sheet's margins, no two cut paths closer than the spacing, every insert hole inside its
    facet, one hole per screw of the kit, neighbours' ids mutual."""
    import glob
    import os

    import ezdxf
    from shapely.geometry import Point, Polygon, box

    w, h = (float(x) for x in a.sheet.lower().split("x"))
    files = sorted(glob.glob(os.path.join(a.dir, "sheet-*.dxf")), key=lambda f: int(f.rsplit("-", 1)[1][:-4]))
    check(len(files) > 0, f"{len(files)} sheet DXF files")
    inner = box(a.margin_mm, a.margin_mm, w - a.margin_mm, h - a.margin_mm)
    ids = []
    holes_total = 0
    neighbours = {}
    for f in files:
        doc = ezdxf.readfile(f)
        name = os.path.basename(f)
        check(doc.header.get("$INSUNITS") == 4, f"{name}: $INSUNITS = 4 (mm)")
        msp = doc.modelspace()
        cuts = [Polygon([(p[0], p[1]) for p in e.get_points()]) for e in msp.query("LWPOLYLINE[layer=='CUT']")]
        check(all(len(e) == 3 and e.closed for e in msp.query("LWPOLYLINE[layer=='CUT']")),
              f"{name}: {len(cuts)} cut paths, each a closed triangle")
        check(all(c.is_valid and c.area > 0 for c in cuts), f"{name}: every cut path a valid polygon")
        out = [i for i, c in enumerate(cuts) if not inner.buffer(1e-6).contains(c)]
        check(not out, f"{name}: every cut path inside the {a.margin_mm} mm margin of the {w:g} x {h:g} mm sheet")
        worst_overlap, closest = 0.0, float("inf")
        for i in range(len(cuts)):
            for j in range(i + 1, len(cuts)):
                if cuts[i].intersects(cuts[j]):
                    worst_overlap = max(worst_overlap, cuts[i].intersection(cuts[j]).area)
                closest = min(closest, cuts[i].distance(cuts[j]))
        check(worst_overlap < 1e-9, f"{name}: no two parts overlap (largest overlap {worst_overlap:.2e} mm²)")
        if len(cuts) > 1:
            check(closest >= a.spacing_mm - 1e-6, f"{name}: closest cut paths {closest:.4f} mm apart >= spacing {a.spacing_mm} mm")
        circles = list(msp.query("CIRCLE[layer=='HOLES']"))
        want_r = (a.hole_mm - a.kerf_mm) / 2
        check(all(abs(c.dxf.radius - want_r) < 1e-9 for c in circles),
              f"{name}: {len(circles)} hole paths of radius {want_r} mm (finished hole {a.hole_mm} mm)")
        per = [0] * len(cuts)
        for c in circles:
            disc = Point(c.dxf.center.x, c.dxf.center.y).buffer(c.dxf.radius, 64)
            owners = [i for i, p in enumerate(cuts) if p.contains(disc)]
            if len(owners) == 1:
                per[owners[0]] += 1
        check(sum(per) == len(circles), f"{name}: every hole inside exactly one facet")
        check(all(k in (8, 16) for k in per), f"{name}: each facet has 8 (trunk edge) or 16 holes: {sorted(set(per))}")
        holes_total += len(circles)
        texts = list(msp.query("TEXT[layer=='LABEL']"))
        for i, c in enumerate(cuts):
            inside = [t for t in texts if c.contains(Point(t.dxf.align_point.x, t.dxf.align_point.y))]
            if not inside:
                check(False, f"{name}: part {i} has no label")
                continue
            own = max(inside, key=lambda t: t.dxf.height)
            ids.append(own.dxf.text)
            neighbours[own.dxf.text] = sorted(t.dxf.text for t in inside if t is not own)
    expected = {f"{k}{kind}{j}" for k in range(1, a.layers + 1) for kind in "AVLU" for j in range(1, a.n + 1)}
    check(sorted(ids) == sorted(expected), f"every facet exactly once: {len(ids)} labelled parts, {len(expected)} expected")
    mutual = all(m in neighbours and i in neighbours[m] for i, ns in neighbours.items() for m in ns)
    check(mutual, "every neighbour label is mutual (A names B across a crease, B names A)")
    edge = [i for i, ns in neighbours.items() if len(ns) == 2]
    check(sorted(edge) == sorted([f"1A{j}" for j in range(1, a.n + 1)] + [f"{a.layers}V{j}" for j in range(1, a.n + 1)]),
          f"only the trunk's bottom and top triangles lack a neighbour ({len(edge)})")
    if a.kit:
        kit = json.load(open(a.kit))
        check(holes_total == kit["screws"], f"{holes_total} insert holes = the kit's {kit['screws']} screws")
    doc = json.load(open(os.path.join(a.dir, "nest.json")))
    check(doc["sheets_used"] == len(files) and doc["area_bound_sheets"] <= len(files),
          f"nest.json: {doc['sheets_used']} sheets, area bound {doc['area_bound_sheets']}")


def cmd_tiles(a):
    """Paper tiles read back with ElementTree: each page 1:1 in mm, its registration marks (the
    crossing of each mark's two lines) put the pages together by translation, every shared mark
    agrees within 0.1 mm, and the assembled crease lines are the full 1:1 pattern's within 0.1 mm
    (each page line lies on a full-pattern line, each full-pattern line is covered)."""
    ns = "{http://www.w3.org/2000/svg}"
    kinds = ["mountain", "valley", "boundary", "cut", "virtual"]

    def mm(v):
        return float(v[:-2]) if v.endswith("mm") else None

    def read(path):
        root = ET.parse(path).getroot()
        lines = []
        for g in root.iter(ns + "g"):
            if g.get("id") in kinds:
                for ln in g.iter(ns + "line"):
                    lines.append((g.get("id"), (float(ln.get("x1")), float(ln.get("y1"))), (float(ln.get("x2")), float(ln.get("y2")))))
        marks = {}
        for g in root.iter(ns + "g"):
            if g.get("class") == "registration":
                ls = list(g.iter(ns + "line"))
                hx = [l for l in ls if l.get("y1") == l.get("y2")][0]
                vy = [l for l in ls if l.get("x1") == l.get("x2")][0]
                marks[g.get("id")] = (float(vy.get("x1")), float(hx.get("y1")))
        return root, lines, marks

    _, full, _ = read(a.full)
    pages = []
    for f in a.pages:
        root, lines, marks = read(f)
        vb = [float(x) for x in root.get("viewBox").split()]
        w, h = mm(root.get("width")), mm(root.get("height"))
        check(w is not None and abs(w - vb[2]) < 1e-9 and abs(h - vb[3]) < 1e-9,
              f"{f.rsplit('/', 1)[-1]}: {w} × {h} mm page, viewBox in mm (1:1)")
        check(any(abs(w - s[0]) < 1e-6 and abs(h - s[1]) < 1e-6 for s in [(210, 297), (297, 210), (215.9, 279.4), (279.4, 215.9)]),
              f"{f.rsplit('/', 1)[-1]}: an A4 or Letter page")
        pages.append((lines, marks))
    # Translations by breadth-first search over shared marks; page 0 is the reference.
    shift = {0: (0.0, 0.0)}
    worst = 0.0
    todo = [0]
    while todo:
        i = todo.pop()
        for j in range(len(pages)):
            shared = set(pages[i][1]) & set(pages[j][1])
            if i == j or not shared:
                continue
            ds = [(pages[i][1][m][0] - pages[j][1][m][0] + shift[i][0], pages[i][1][m][1] - pages[j][1][m][1] + shift[i][1]) for m in shared]
            if j not in shift:
                shift[j] = ds[0]
                todo.append(j)
            worst = max([worst] + [math.dist(d, shift[j]) for d in ds])
    check(len(shift) == len(pages), f"every page joined to the others through shared marks ({len(shift)} of {len(pages)})")
    check(worst <= 0.1, f"shared registration marks agree within 0.1 mm (worst {worst:.2e} mm)")
    assembled = [(k, (p[0] + shift[i][0], p[1] + shift[i][1]), (q[0] + shift[i][0], q[1] + shift[i][1]))
                 for i, (lines, _) in enumerate(pages) if i in shift for (k, p, q) in lines]
    # The assembled frame against the full pattern's: the offset of their top-left corners.
    off = (min(min(p[0], q[0]) for _, p, q in full) - min(min(p[0], q[0]) for _, p, q in assembled),
           min(min(p[1], q[1]) for _, p, q in full) - min(min(p[1], q[1]) for _, p, q in assembled))
    assembled = [(k, (p[0] + off[0], p[1] + off[1]), (q[0] + off[0], q[1] + off[1])) for k, p, q in assembled]

    def seg_dist(p, a_, b_):
        dx, dy = b_[0] - a_[0], b_[1] - a_[1]
        L2 = dx * dx + dy * dy
        t = 0 if L2 == 0 else max(0, min(1, ((p[0] - a_[0]) * dx + (p[1] - a_[1]) * dy) / L2))
        return math.dist(p, (a_[0] + t * dx, a_[1] + t * dy))

    off_line = 0.0
    for k, p, q in assembled:
        best = min(max(seg_dist(p, fa, fb), seg_dist(q, fa, fb)) for fk, fa, fb in full if fk == k)
        off_line = max(off_line, best)
    check(off_line <= 0.1, f"{len(assembled)} page lines lie on the full pattern's lines of their kind within 0.1 mm (worst {off_line:.2e} mm)")
    uncovered = 0
    for k, fa, fb in full:
        for t in (0.05, 0.5, 0.95):
            pt = (fa[0] + t * (fb[0] - fa[0]), fa[1] + t * (fb[1] - fa[1]))
            if min((seg_dist(pt, p, q) for kk, p, q in assembled if kk == k), default=1e9) > 0.1:
                uncovered += 1
    check(uncovered == 0, f"all {len(full)} lines of the full pattern are on the pages ({uncovered} points missing)")


def read_glb(path):
    """Reads a binary glTF written by host-tool (non-indexed triangles, float POSITION and
    COLOR_0) with numpy alone: returns (triangles (k, 3, 3) in mm with +Z up, sRGB colours (k, 3))."""
    import struct

    import numpy as np

    data = open(path, "rb").read()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    check(magic == b"glTF" and version == 2 and length == len(data), f"{path}: GLB header, version 2, length {length}")
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    doc = json.loads(data[20:20 + jlen])
    blen, btype = struct.unpack_from("<I4s", data, 20 + jlen)
    check(jtype == b"JSON" and btype == b"BIN\0", f"{path}: JSON and BIN chunks")
    binary = data[28 + jlen:28 + jlen + blen]
    check(doc["asset"]["version"] == "2.0", f"{path}: asset.version 2.0")
    prim = doc["meshes"][0]["primitives"][0]

    def accessor(i, width):
        acc = doc["accessors"][i]
        view = doc["bufferViews"][acc["bufferView"]]
        off = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        arr = np.frombuffer(binary, dtype="<f4", count=acc["count"] * width, offset=off)
        return arr.reshape(acc["count"], width).astype(float), acc

    pos, pacc = accessor(prim["attributes"]["POSITION"], 3)
    col, _ = accessor(prim["attributes"]["COLOR_0"], 4)
    check(np.allclose(pos.min(axis=0), pacc["min"], atol=1e-6) and np.allclose(pos.max(axis=0), pacc["max"], atol=1e-6),
          f"{path}: POSITION min/max match the data")
    # glTF metres, +Y up -> mm, +Z up.
    mm = np.column_stack([pos[:, 0], -pos[:, 2], pos[:, 1]]) * 1000.0
    lin = np.clip(col[:, :3], 0, 1)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return mm.reshape(-1, 3, 3), srgb.reshape(-1, 3, 3)[:, 0, :]


def cmd_render(a):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    tris, cols = [], []
    for spec in a.file.split(","):
        path, _, colour = spec.partition("=")
        if path.lower().endswith(".glb"):
            t, c = read_glb(path)
        else:
            import trimesh

            m = trimesh.load(path, force="mesh")
            t = m.vertices[m.faces]
            if colour:
                c = np.tile(np.array(matplotlib.colors.to_rgb(colour)), (len(t), 1))
            elif m.visual.kind:
                c = m.visual.face_colors[:, :3] / 255.0
            else:
                c = np.full((len(t), 3), 0.7)
        tris.append(t)
        cols.append(c)
    tri, colours = np.concatenate(tris), np.concatenate(cols)
    if a.top:
        # Orthographic top view, painted bottom-up by height (exact for flat layered parts).
        from matplotlib.collections import PolyCollection

        order = np.argsort(tri[:, :, 2].max(axis=1), kind="stable")
        fig, ax = plt.subplots(figsize=(a.size, a.size))
        ax.add_collection(PolyCollection(tri[order][:, :, :2], facecolors=colours[order], edgecolors="none"))
        ax.autoscale()
        ax.set_aspect("equal")
        ax.set_xlabel("mm")
        ax.set_ylabel("mm")
        if a.title:
            ax.set_title(a.title.replace("\\n", "\n"), fontsize=9)
        fig.tight_layout()
        fig.savefig(a.out, dpi=a.dpi)
        print(f"ok   rendered {a.file} -> {a.out}")
        return
    fig = plt.figure(figsize=(a.size, a.size))
    ax = fig.add_subplot(projection="3d")
    # Light: shade by the face normal's angle to a fixed direction.
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
    light = np.array([0.3, -0.5, 0.8])
    light /= np.linalg.norm(light)
    shade = 0.55 + 0.45 * np.abs(n @ light)
    ax.add_collection3d(Poly3DCollection(tri, facecolors=np.clip(colours * shade[:, None], 0, 1),
                                         edgecolors=(0, 0, 0, 0.35), linewidths=0.3))
    v = tri.reshape(-1, 3)
    lo, hi = v.min(axis=0), v.max(axis=0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.view_init(elev=a.elev, azim=a.azim)
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()
    if a.title:
        ax.set_title(a.title.replace("\\n", "\n"), fontsize=9)
    fig.tight_layout()
    fig.savefig(a.out, dpi=a.dpi)
    print(f"ok   rendered {a.file} -> {a.out}")


def cmd_glb(a):
    import numpy as np

    for f in a.files:
        tri, colours = read_glb(f)
        check(len(tri) > 0 and np.isfinite(tri).all(), f"{f}: {len(tri)} finite triangles")
        red = int(np.sum((colours[:, 0] > 0.8) & (colours[:, 1] < 0.2)))
        print(f"info {f}: {red} faces drawn strain-red")
        if a.expect_red is not None:
            check((red > 0) == a.expect_red, f"{f}: strained faces {'present' if a.expect_red else 'absent'}")


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("dxf")
    d.add_argument("file")
    d.add_argument("--fold", required=True)
    d.add_argument("--edge-mm", type=float, required=True)
    d.add_argument("--seam-mm", type=float, required=True)
    pn = sub.add_parser("panel")
    pn.add_argument("file")
    pn.add_argument("--stl-dir")
    m = sub.add_parser("mesh")
    m.add_argument("files", nargs="+")
    m.add_argument("--closed", action="store_true")
    pa = sub.add_parser("parts")
    pa.add_argument("report", help="the JSON of host-tool pattern --parts DIR -j")
    pa.add_argument("--expect", nargs="+", default=["hinge-leaf", "upper-cap", "lower-cap", "tendon-locator", "gripper-mount"])
    pa.add_argument("--tendon-radius-mm", type=float)
    pa.add_argument("--formats", choices=["stl", "both"], default="both", help="the --parts-format the report was made with")
    bo = sub.add_parser("bom")
    bo.add_argument("file")
    bo.add_argument("--parts", required=True, help="the JSON of host-tool pattern --parts DIR -j")
    bo.add_argument("--expect", nargs="+", default=["upper-cap", "lower-cap", "tendon-locator", "gripper-mount"])
    lg = sub.add_parser("legend")
    lg.add_argument("files", nargs="+")
    lg.add_argument("--expect", choices=["legend", "none"], default="legend")
    lg.add_argument("--margin-mm", type=float, default=10.0)
    lg.add_argument("--footer-mm", type=float, default=0.0)
    k = sub.add_parser("kit")
    k.add_argument("file")
    k.add_argument("--hinges", type=int, required=True)
    k.add_argument("--screws", type=int, required=True)
    ne = sub.add_parser("nest")
    ne.add_argument("dir")
    ne.add_argument("--sheet", required=True)
    ne.add_argument("--margin-mm", type=float, default=10.0)
    ne.add_argument("--spacing-mm", type=float, default=3.0)
    ne.add_argument("--kerf-mm", type=float, default=0.2)
    ne.add_argument("--hole-mm", type=float, default=5.6)
    ne.add_argument("--n", type=int, required=True)
    ne.add_argument("--layers", type=int, required=True)
    ne.add_argument("--kit")
    ti = sub.add_parser("tiles")
    ti.add_argument("full")
    ti.add_argument("pages", nargs="+")
    gl = sub.add_parser("glb")
    gl.add_argument("files", nargs="+")
    gl.add_argument("--expect-red", type=lambda x: x == "yes", default=None)
    r = sub.add_parser("render")
    r.add_argument("file", help="FILE[=colour][,FILE[=colour]...]")
    r.add_argument("out")
    r.add_argument("--title", default="")
    r.add_argument("--top", action="store_true", help="orthographic top view")
    r.add_argument("--elev", type=float, default=20)
    r.add_argument("--azim", type=float, default=-60)
    r.add_argument("--size", type=float, default=5)
    r.add_argument("--dpi", type=int, default=110)
    a = p.parse_args()
    {"dxf": cmd_dxf, "panel": cmd_panel, "mesh": cmd_mesh, "kit": cmd_kit, "render": cmd_render, "glb": cmd_glb, "nest": cmd_nest, "tiles": cmd_tiles, "parts": cmd_parts, "bom": cmd_bom, "legend": cmd_legend}[a.cmd](a)
    print(f"check_outputs {a.cmd}: " + ("all checks passed" if FAILED == 0 else f"{FAILED} checks FAILED"))
    sys.exit(1 if FAILED else 0)


if __name__ == "__main__":
    main()
