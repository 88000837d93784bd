"""The Debian packages real objects come from: download, extraction and the candidate models.

Each package is fetched with ``apt-get download`` and unpacked with ``dpkg-deb -x`` (never
installed: installing pulls in Java and games) under ``<cache>/debs`` and ``<cache>/pkgs``
(git-ignored). :func:`find_candidates` walks the unpacked trees and lists the model files
worth looking at (:data:`RULES`: which folders hold aircraft, boats, road vehicles, street
lamps, furniture and guns), each with the category it is looked at for.

Scored by nothing yet: the real-objects study will read ``experiments/real_objects/catalogue.csv``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path

PACKAGES = {
    "flightgear-data-base": ("fg", "GPL-2.0-or-later"),
    "flightgear-data-ai": ("fgai", "GPL-2.0-or-later"),
    "flightgear-data-models": ("fgm", "GPL-2.0-or-later"),
    "torcs-data": ("torcs", "GPL-2.0-or-later"),
    "ufoai-data": ("ufo", "GPL-2.0-or-later"),
    "gl-117-data": ("gl117", "GPL-2.0-only"),
    "openarena-data": ("oa", "GPL-2.0-or-later"),
    "minetest-mod-homedecor": ("hd", "CC-BY-SA-4.0"),
    "sweethome3d": ("sh3d", "GPL-2.0-or-later"),
}
"""Each Debian package: the short code used in our ids and its licence as its
``/usr/share/doc/PKG/copyright`` states it for the model files (``Files: *``; UFO:AI's
copyright file names other licences for many files: :func:`ufoai_licences`)."""
MEMBER_SEP = "::"
"""Joins an archive (``.pk3``/``.jar``) and a member in a candidate's path."""


@dataclass(frozen=True)
class Candidate:
    """One model file worth looking at: its package, its path inside the unpacked package
    (``archive::member`` for a model inside a zip), the category it is looked at for, and
    its licence (SPDX)."""

    source: str
    path: str
    category: str
    licence: str


def download(cache: str | os.PathLike, packages: list[str] | None = None) -> dict[str, float]:
    """``apt-get download`` each package (:data:`PACKAGES`) into ``<cache>/debs`` unless its
    ``.deb`` is there; returns the seconds each took. Needs network and Debian's apt."""
    debs = Path(cache) / "debs"
    debs.mkdir(parents=True, exist_ok=True)
    times = {}
    for name in packages or list(PACKAGES):
        if list(debs.glob(f"{name}_*.deb")):
            continue
        start = time.monotonic()
        subprocess.run(["apt-get", "download", name], cwd=debs, check=True)
        times[name] = time.monotonic() - start
    return times


def extract(cache: str | os.PathLike, packages: list[str] | None = None) -> dict[str, float]:
    """``dpkg-deb -x`` each downloaded ``.deb`` into ``<cache>/pkgs/<package>`` unless that
    folder exists; returns the seconds each took."""
    cache = Path(cache)
    times = {}
    for name in packages or list(PACKAGES):
        debs = sorted((cache / "debs").glob(f"{name}_*.deb"))
        if not debs:
            raise FileNotFoundError(f"{cache / 'debs'}: no {name}_*.deb; run the download "
                                    "step first (python -m e2vlib.experiments.real_objects "
                                    "download)")
        out = cache / "pkgs" / name
        if out.is_dir():
            continue
        start = time.monotonic()
        tmp = out.with_name(name + ".part")
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.parent.mkdir(parents=True, exist_ok=True)  # dpkg-deb makes the last folder only
        subprocess.run(["dpkg-deb", "-x", str(debs[-1]), str(tmp)], check=True)
        tmp.rename(out)
        times[name] = time.monotonic() - start
    return times


FG = "usr/share/games/flightgear"
RULES: list[tuple[str, str, str, str]] = [
    # (package, regex on the path inside the package, category, regex of paths left out)
    ("flightgear-data-base", rf"{FG}/Scenery/Models/Aircraft/[^/]+\.ac", "airplane",
     r"(?i)heli|ec-?1[23]5|^r44|^r22|mi-8|lynx|puma|alouette|bo-?105|uh-?1|ch-?47|chinook|"
     r"gazelle|^dauphin|as350|services|jetway|_roue|-roue|wheel|h-?60"),
    ("flightgear-data-ai", rf"{FG}/AI/Aircraft/[^/]+/(Models?/|Models/rnlaf/)?[^/]+\.ac",
     "airplane", r"(?i)heli|balloon|^lights?|-light|light-|flare|prop|refuel|probe|strobe|"
     r"beacon|shadow|gear|rotor|interior|cockpit|pilot|OMSPods|SSME|ferry|WhiteLight"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/Airport/av8jet\.ac", "airplane", r"^$"),
    ("flightgear-data-base", rf"{FG}/Aircraft/c172p/Models/c172p\.ac", "airplane", r"^$"),
    ("flightgear-data-models", rf"{FG}/Models/Geometry/(KA6-D/KA6-D|KC135/KC135|"
     r"A4-F/a4-f-tanker|KC-130/KC-130|glider)\.ac", "airplane", r"^$"),
    ("flightgear-data-models", rf"{FG}/Models/Geometry/(saratoga|sailboat1/sailboat|"
     r"Clemenceau/hull|Nimitz/(nimitz|vinson|truman))\.ac", "watercraft", r"^$"),
    ("flightgear-data-base", rf"{FG}/Scenery/Objects/[^/]+/[^/]+/(USSArizona|T45_D36_moored|"
     r"sanmateo-fb)\.ac", "watercraft", r"^$"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/(Maritime/Misc/Narrowboat[^/]*|"
     r"Sport/Optimist)\.ac", "watercraft", r"^$"),
    ("flightgear-data-models", rf"{FG}/Models/Aircraft/[^/]+\.ac", "airplane",
     r"(?i)H-60|strobe|dauphin|testpilot|towropes"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/Maritime/(Civilian|Military)/.+\.ac",
     "watercraft", r"(?i)lighthouse|oberfeuer|crane|ponton|pier|buoy|beacon|light|"
     r"mooring|dock|wake"),
    ("flightgear-data-models", rf"{FG}/Models/Maritime/(Civilian|Military)/.+\.ac",
     "watercraft", r"(?i)lighthouse|crane|ponton|pier|buoy|beacon|light|dock|wake"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/Maritime/Misc/liferaft.*\.ac",
     "watercraft", r"^$"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/(Transport|Airport/Vehicle)/[^/]+\.ac",
     "car", r"(?i)container|train|coach|ice3|locomotive|loco|wagon(?!taxi)|platform|station|barrel|"
     r"tunnel|carpark|trailer|(?<!mini)bus(?!small)|(?<!com)truck|tender|metro|tram|class_|hitachi|lint|flatcar|"
     r"switcher|diesel|grader|roller|digger|dozer|forklift|dumptruck|steamroller|"
     r"consbrooms|grit|flash|dolly|cart|loader|stairs|gpu|cobus|citerne|chariot|caisses|"
     r"catruck|catering|lugg|fire|rosenbauer|panther|tlf|oshkosh|hoskosh|tug|tractor|"
     r"deicer|de-icer|lift|pushback|volocopter|fuel|f600|gwg|egkk|kontener|fc6m|"
     r"norbert|eddi-flugverkehr|voyager|srn4|mxvt|fedex|usps|ups"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/StreetFurniture/[^/]+\.ac", "lamp",
     r"(?i)^(?!.*(lamp|light)).*$|barrier|crossing|pelican"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/(Misc|Sport|Residential)/"
     r"(parkbench|picnic|table|swing|strandkorb|stmartin_lamp|recliners)[^/]*\.ac", "bench",
     r"^$"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/(Airport|Misc|Power|Industrial|"
     r"Communications)/[^/]*([Ll]amp|[Ll]ight[-_ ]?[Pp]ole|[Ff]loodlight|[Mm]ast[-_]?light)"
     r"[^/]*\.ac", "lamp", r"^$"),
    ("flightgear-data-base", rf"{FG}/Scenery/Models/Military/(humvee|F-16|KC10)[^/]*\.ac",
     "car", r"^$"),
    ("torcs-data", r"usr/share/games/torcs/cars/[^/]+/[^/]+\.acc", "car",
     r"(?i)wheel|shadow|lod|-lod|_lod|[-_]s\d?\.acc|driver|cockpit|steer"),
    ("gl-117-data", r"usr/share/games/gl-117/models/[^/]+\.3ds", "airplane",
     r"(?i)missile|flare|chaff|cannon|flak|house|hall|tent|depot|container|barrier|wall|"
     r"rubble|aster|egg|mine|radar|base|oilrig|sam|flarak"),
    ("minetest-mod-homedecor", r".+\.obj", "chair", r"^$"),
]
"""Where the candidates lie: (package, regex the path inside the package must match,
category looked at for, regex of paths left out as plainly not of that category: parts,
lights, helicopters, trains, trucks, buildings). The category of vehicles in the
``*-data`` folders of cars (``Airport/Vehicle``) is ``car`` for those kept; the category
of each minetest and pk3 candidate is set by :func:`_archive_candidates` and the review."""

UFOAI_RULES = [
    (r"models/weapons/[^/]+/[^/]+\.md2", "rifle",
     r"(?i)_ammo|ammo|clip|mag|grenade|knife|kerrblade|flashbang|smoke|stun|medikit|"
     r"shell|bullet|mine|arrow|incgren|fraggren|_hud|_fp"),
    (r"models/objects/japan/stoel\.md2", "chair", r"^$"),
    (r"models/objects/furniture/locker/[^/]+\.md2", "cabinet", r"^$"),
    (r"models/objects/construct/workbench/[^/]+\.md2", "table", r"^$"),
    (r"models/objects/industrial/console/console\.md2", "display", r"^$"),
    (r"models/objects/cars/.+\.md2", "car", r"(?i)trailer|roof|crashed|_t\.md2"),
    (r"models/objects/(aircraft/(airplane|fighter)|boat)/.+\.md2", "airplane", r"(?i)engine"),
    (r"models/aircraft/(drop|inter|ufo)_[^/]+/[^/]+\.md2", "airplane",
     r"(?i)gear|_int|seats|box|wall|pod|carryall|extinguiser|hull|engine|upper|wing|"
     r"container|_top|folded|closed|landed|flying|_low|herakles_[23]|body"),
    (r"models/objects/(furniture/chairs|city/(bench|parkbench|parktable)|japan/stoel|"
     r"alien/seat)/.+\.md2", "chair", r"^$"),
    (r"models/objects/(furniture/desklamp|industrial/lamp|city/(lantern|light))/.+\.md2",
     "lamp", r"^$"),
    (r"models/objects/(furniture/(desk|comptable)|city/parktable)/.+\.md2", "table", r"^$"),
]
"""UFO:AI's ``base/0models.pk3``: (member regex, category, regex left out)."""

OPENARENA_RULES = [
    (r"models/weapons2/[^/]+/[^/]+\.md3", "rifle",
     r"(?i)flash|barrel|hand|shell|_\d\.md3|gauntlet|grenadel|bfg"),
    (r"models/weapons/nailgun/nailgun\.md3", "rifle", r"^$"),
]
"""OpenArena's ``baseoa/pak0.pk3``: (member regex, category, regex left out)."""

SH3D_JAR = "usr/share/sweethome3d/sweethome3d.jar"
SH3D_RULES = [
    (r"(?i).*/resources/.*(chair|stool|bench)[^/]*\.obj", "chair", r"(?i)wheelchair"),
    (r"(?i).*/resources/.*(table|desk)[^/]*\.obj", "table", r"(?i)bedside|vegetable"),
    (r"(?i).*/resources/.*(lamp|uplight|light)[^/]*\.obj", "lamp", r"(?i)lightsource"),
    (r"(?i).*/resources/.*(sofa|couch|settee)[^/]*\.obj", "sofa", r"^$"),
    (r"(?i).*/resources/.*(cabinet|bookcase|dresser|chest|wardrobe|shelves|sideboard|"
     r"cupboard|bedsidetable|chestofdrawers)[^/]*\.obj", "cabinet", r"^$"),
    (r"(?i).*/resources/.*(tv|television|monitor|screen)[^/]*\.obj", "display", r"^$"),
    (r"(?i).*/resources/.*(laptop|computer)[^/]*\.obj", "display", r"^$"),
]
"""Sweet Home 3D's own catalogue inside its jar: (member regex, category, regex left out)."""

HOMEDECOR_CATEGORIES = [
    (r"(?i)lamp|light|lantern|chandelier|sconce|plasma_ball|candlestick", "lamp"),
    (r"(?i)kitchen_sink|wine_rack", "cabinet"),
    (r"(?i)chair|stool|seat|bench", "chair"),
    (r"(?i)table|desk", "table"),
    (r"(?i)cabinet|dresser|wardrobe|nightstand|shelf|shelves|drawer|cupboard|bookcase|"
     r"kitchen_cabinet|filing", "cabinet"),
    (r"(?i)sofa|couch|loveseat", "sofa"),
    (r"(?i)tv|television|monitor|computer|screen", "display"),
    (r"(?i)speaker|stereo|radio", "speaker"),
    (r"(?i)phone", "telephone"),
]
"""minetest-mod-homedecor's OBJ files: the category their file name suggests (others are
not candidates)."""


def _match(rules, path: str) -> str | None:
    for pattern, category, leave_out in rules:
        if re.fullmatch(pattern, path) and not re.search(leave_out, path.rsplit("/", 1)[-1]):
            return category
    return None


SPDX = {"GPL-2+": "GPL-2.0-or-later", "GPL-2": "GPL-2.0-only", "GPL-3+": "GPL-3.0-or-later",
        "public-domain": "public-domain", "CC-BY-SA-3.0": "CC-BY-SA-3.0",
        "CC-BY-3.0": "CC-BY-3.0"}
"""Debian copyright-file licence names as SPDX names."""


def ufoai_licences(pkgs: str | os.PathLike) -> dict[str, str]:
    """UFO:AI's per-file licences from Debian's copyright file (machine-readable format):
    ``{member path inside base/*.pk3: SPDX}`` for every file a ``Files:`` stanza names under
    ``base/`` (the rest are ``Files: *``, GPL-2.0-or-later); empty when the file is absent.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> doc = root / "ufoai-data/usr/share/doc/ufoai-data"
    >>> doc.mkdir(parents=True)
    >>> _ = (doc / "copyright").write_text("Files: *\\nLicense: GPL-2+\\n\\nFiles:\\n"
    ...     " base/models/a.md2\\n base/models/b.md2\\nCopyright: X\\nLicense: CC-BY-SA-3.0\\n")
    >>> ufoai_licences(root)
    {'models/a.md2': 'CC-BY-SA-3.0', 'models/b.md2': 'CC-BY-SA-3.0'}
    """
    path = Path(pkgs) / "ufoai-data/usr/share/doc/ufoai-data/copyright"
    if not path.is_file():
        return {}
    found, files, in_files = {}, [], False
    for line in path.read_text(errors="replace").splitlines():
        if line.startswith("Files:"):
            files, in_files = line[6:].split(), True
        elif line.startswith(" ") and in_files:
            files += line.split()
        elif line.startswith("License:"):
            name = line[8:].strip()
            for f in files:
                if f.startswith("base/"):
                    found[f[5:]] = SPDX.get(name, name)
            files, in_files = [], False
        else:
            in_files = False
    return found


def find_candidates(cache: str | os.PathLike) -> list[Candidate]:
    """Every candidate model of the unpacked packages under ``<cache>/pkgs``, sorted by
    package and path (:data:`RULES` and the archive rules)."""
    pkgs = Path(cache) / "pkgs"
    out = []
    for source, pattern, category, leave_out in RULES:
        root = pkgs / source
        if source == "minetest-mod-homedecor":
            continue
        for path in sorted(root.rglob("*")):
            rel = path.relative_to(root).as_posix()
            if (path.is_file() and re.fullmatch(pattern, rel)
                    and not re.search(leave_out, path.name)):
                out.append(Candidate(source, rel, category, PACKAGES[source][1]))
    out += _archive_candidates(pkgs)
    seen, unique = set(), []
    for c in out:
        if (c.source, c.path) not in seen:
            seen.add((c.source, c.path))
            unique.append(c)
    return sorted(unique, key=lambda c: (c.source, c.path))


def _archive_candidates(pkgs: Path) -> list[Candidate]:
    out = []
    root = pkgs / "minetest-mod-homedecor"
    for path in sorted(root.rglob("*.obj")):
        for pattern, category in HOMEDECOR_CATEGORIES:
            if re.search(pattern, path.stem):
                out.append(Candidate("minetest-mod-homedecor",
                                     path.relative_to(root).as_posix(), category,
                                     PACKAGES["minetest-mod-homedecor"][1]))
                break
    for source, archive, rules in (
            ("ufoai-data", "usr/share/games/ufoai/base/0models.pk3", UFOAI_RULES),
            ("openarena-data", "usr/share/games/openarena/baseoa/pak0.pk3", OPENARENA_RULES),
            ("openarena-data", "usr/share/games/openarena/missionpack/mp-pak0.pk3",
             OPENARENA_RULES),
            ("sweethome3d", SH3D_JAR, SH3D_RULES)):
        path = pkgs / source / archive
        if not path.is_file():
            continue
        licences = ufoai_licences(pkgs) if source == "ufoai-data" else {}
        with zipfile.ZipFile(path) as zf:
            for member in sorted(zf.namelist()):
                category = _match(rules, member)
                if category:
                    licence = licences.get(member, PACKAGES[source][1])
                    out.append(Candidate(source, f"{archive}{MEMBER_SEP}{member}", category,
                                         licence))
    return out
