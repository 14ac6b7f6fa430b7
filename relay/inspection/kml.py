"""Mission targets from the placemarks of a KML or KMZ file (Google Earth, QGIS, simplekml, ...).

``targets_from_kml(data, name, geo)`` reads a ``.kml`` (XML) or a ``.kmz`` (a zip holding ``doc.kml``, else its
first ``.kml`` in archive order, as Google Earth does) and makes every Placemark with a Point a ``Target``:

- ``id``: the placemark's ``id`` attribute, else a slug of its name (``"Gas valve 1"`` -> ``gas-valve-1``); an id
  that is not a target id (letters, digits, ``_``, ``-``; at most 64) is slugged too. An all-digit id is taken for
  the writing tool's counter and the name is slugged instead: simplekml numbers every object from a process-wide
  counter (``id="3"``), so the same placemark gets another id on every export, and missions name targets by id.
  Ids are made unique by appending ``-2``, ``-3``, ... in file order.
- ``name``: the ``<name>`` text (whitespace collapsed), else the id.
- ``kind``: the ExtendedData field ``kind`` (``<Data name="kind"><value>`` or ``<SimpleData name="kind">``), else
  ``"point"``.
- ``facing``: the ExtendedData field ``facing`` in degrees, as radians; the same convention as the targets YAML
  (``relay.inspection.targets``): a yaw in the map frame, counter-clockwise from the map's +x axis. None if absent.
- ``(x, y)``: ``to_map(geo, lat, lon)``.

Placemarks with a LineString, a Polygon, a MultiGeometry or a gx:Track are ignored: a target is a point.

KML coordinates are longitude/latitude (WGS84), so placing targets needs a ``Georeference``: where the map frame's
origin is on Earth and how it is turned. ``to_map`` is an equirectangular projection around that origin (metres per
degree of latitude and of longitude on the WGS84 ellipsoid at the origin's latitude, then the map's yaw). Measured
against Vincenty's geodesic distance and azimuth from the origin (tests/test_kml.py), over all directions, the
position error at 1 km from the origin is 0.02 m at 15 degrees latitude, 0.09 m at 45, 0.16 m at 60 and 0.25 m at
70 (0.5 m at 80); it is mostly the meridians' convergence and grows with the square of the distance (2.3 m at 5 km,
9 m at 10 km, at 45 degrees). A placemark more than ``MAX_DISTANCE`` from the origin is refused: it would be
metres off, and is more likely a wrong georeference (lat and lon swapped) or a file of another site.

Untrusted input: the XML is parsed with defusedxml (no entity expansion, no external entities or DTD fetches, so
"billion laughs" fails at its first entity declaration); a KMZ may hold at most ``MAX_UNCOMPRESSED`` bytes
uncompressed in all (checked against the zip's directory, so a zip bomb fails before anything inflates; one whose
directory understates its sizes fails on its CRC once the claimed bytes are out); a file may hold at most
``MAX_PLACEMARKS`` placemarks. Every error is a ``KmlError`` (a ValueError) naming the file and, where one is at
fault, the placemark.

Pure: bytes in, targets out.
"""

from __future__ import annotations

import io
import math
import re
import unicodedata
import zipfile
import zlib
from dataclasses import dataclass
from xml.etree.ElementTree import Element

import defusedxml.ElementTree as SafeET
from defusedxml import DefusedXmlException

from .records import TARGET_ID, Target

#: A KMZ's entries may inflate to this many bytes in all; a plain KML may be this large. Google Earth's own
#: site files are well under 1 MB; 10,000 placemarks with ExtendedData are ~5 MB.
MAX_UNCOMPRESSED = 20 * 1024 * 1024
#: Placemarks (of any geometry) a file may hold: more is not a site's targets list.
MAX_PLACEMARKS = 10_000
#: Metres from the georeference origin beyond which a placemark is refused: there the projection is off by
#: 2.3 m at 45 degrees latitude (6 m at 70), more than a robot's standoff distance (module docstring).
MAX_DISTANCE = 5_000.0

# WGS84 ellipsoid.
_A = 6_378_137.0  # semi-major axis (m)
_F = 1 / 298.257223563  # flattening
_E2 = _F * (2 - _F)  # first eccentricity squared


class KmlError(ValueError):
    """A KML/KMZ file that cannot be read into targets; the message names the file and what to change."""


@dataclass(frozen=True, slots=True)
class Georeference:
    """Where the map frame is on Earth: its origin (0, 0) at (lat, lon) in degrees (WGS84), its +x axis ``yaw``
    radians counter-clockwise from east (0: +x east, +y north, as REP 103 has it for ENU frames)."""

    lat: float
    lon: float
    yaw: float = 0.0

    def __post_init__(self) -> None:
        # |lat| < 89: near a pole a degree of longitude shrinks to nothing and the projection degenerates.
        if not (math.isfinite(self.lat) and -89.0 < self.lat < 89.0):
            raise ValueError(f"georeference lat {self.lat} must be a latitude in degrees between -89 and 89")
        if not (math.isfinite(self.lon) and -180.0 <= self.lon <= 180.0):
            raise ValueError(f"georeference lon {self.lon} must be a longitude in degrees between -180 and 180")
        if not math.isfinite(self.yaw):
            raise ValueError(f"georeference yaw {self.yaw} must be a finite angle in radians")


def to_map(geo: Georeference, lat: float, lon: float) -> tuple[float, float]:
    """The map-frame (x, y) in metres of (lat, lon) in degrees: equirectangular around ``geo``'s origin on WGS84.

    East and north offsets use the ellipsoid's radii of curvature at the origin's latitude: the meridional radius
    for north (~111.1 km per degree) and the prime-vertical radius times cos(lat) for east; then the map's yaw turns
    (east, north) into (x, y). Error against the geodesic: see the module docstring.
    """
    phi = math.radians(geo.lat)
    w = 1.0 - _E2 * math.sin(phi) ** 2
    meridional = _A * (1.0 - _E2) / w**1.5  # metres per radian of latitude
    prime_vertical = _A / math.sqrt(w)  # times cos(lat): metres per radian of longitude
    dlon = (lon - geo.lon + 180.0) % 360.0 - 180.0  # across the antimeridian the short way
    east = math.radians(dlon) * prime_vertical * math.cos(phi)
    north = math.radians(lat - geo.lat) * meridional
    # The map's +x is ``yaw`` counter-clockwise from east: project (east, north) onto the map's axes.
    c, s = math.cos(geo.yaw), math.sin(geo.yaw)
    return east * c + north * s, -east * s + north * c


def targets_from_kml(data: bytes, name: str, geo: Georeference | None) -> list[Target]:
    """The targets of the Point placemarks of ``data`` (a .kml or .kmz); ``name`` is the file's name for messages.

    Raises KmlError for a corrupt or oversized file, XML that is not KML or uses entities, a Point with bad
    coordinates or ExtendedData, more than ``MAX_PLACEMARKS`` placemarks, or Point placemarks without ``geo``.
    """
    root = _parse(_kml_bytes(data, name), name)
    placemarks = [element for element in root.iter() if _local(element.tag) == "Placemark"]
    if len(placemarks) > MAX_PLACEMARKS:
        raise KmlError(f"{name}: {len(placemarks)} placemarks, at most {MAX_PLACEMARKS}: split the file")
    targets: list[Target] = []
    used: set[str] = set()
    for number, placemark in enumerate(placemarks, start=1):
        point = _child(placemark, "Point")
        if point is None:
            continue  # a line, an area or a track: not a target
        label = _text(_child(placemark, "name"))
        where = f'{name}: placemark "{label}"' if label else f"{name}: placemark {number} (no name)"
        lat, lon = _coordinates(point, where)
        if geo is None:
            raise KmlError(
                f"{name}: KML coordinates are longitude/latitude; add a georeference to robots.yaml "
                "(georeference: {lat: ..., lon: ..., yaw: 0.0}) to place them in the map frame"
            )
        x, y = to_map(geo, lat, lon)
        if math.hypot(x, y) > MAX_DISTANCE:
            raise KmlError(
                f"{where}: ({lat}, {lon}) is {math.hypot(x, y) / 1000:.1f} km from the georeference "
                f"({geo.lat}, {geo.lon}), more than {MAX_DISTANCE / 1000:.0f} km: is the georeference right "
                "(lat and lon not swapped) and the file of this site?"
            )
        fields = _extended_data(placemark)
        ident = _unique(_identifier(placemark.get("id"), label, number), used)
        targets.append(
            Target(
                id=ident,
                name=label or ident,
                kind=fields.get("kind") or "point",
                x=x,
                y=y,
                facing=_facing(fields.get("facing"), where),
            )
        )
    return targets


def _kml_bytes(data: bytes, name: str) -> bytes:
    """The KML document of ``data``: itself, or the one inside a KMZ."""
    is_zip = data[:2] == b"PK"  # local file header, or the end record of an empty archive
    if not is_zip and name.lower().endswith(".kmz"):
        raise KmlError(f"{name}: not a KMZ (zip) archive; save it again from the tool that made it, or send the .kml")
    if not is_zip:
        if len(data) > MAX_UNCOMPRESSED:
            raise KmlError(f"{name}: {len(data)} bytes, more than {MAX_UNCOMPRESSED // 2**20} MB of KML")
        return data
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            entries = [entry for entry in archive.infolist() if not entry.is_dir()]
            # The directory's claim first: a bomb that declares its size is refused before anything inflates.
            declared = sum(entry.file_size for entry in entries)
            if declared > MAX_UNCOMPRESSED:
                raise KmlError(
                    f"{name}: the KMZ holds {declared} bytes uncompressed, more than {MAX_UNCOMPRESSED // 2**20} MB"
                )
            documents = [
                entry
                for entry in entries
                # Skip macOS resource forks (__MACOSX/._doc.kml): they end in .kml but are not KML.
                if entry.filename.lower().endswith(".kml")
                and not entry.filename.startswith("__MACOSX/")
                and not entry.filename.rsplit("/", 1)[-1].startswith("._")
            ]
            if not documents:
                raise KmlError(f"{name}: the KMZ holds no .kml document (expected doc.kml)")
            chosen = next((entry for entry in documents if entry.filename == "doc.kml"), documents[0])
            # zipfile never inflates past an entry's declared size (a header that understates it ends in a CRC
            # error after that many bytes, tested), so the directory check above bounds this read.
            return archive.read(chosen)
    except KmlError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, RuntimeError, NotImplementedError, ValueError) as error:
        # BadZipFile: a damaged archive or a CRC mismatch; RuntimeError: encrypted entries;
        # NotImplementedError: a compression method Python lacks.
        raise KmlError(f"{name}: the KMZ (zip) archive cannot be read: {error}") from error


def _parse(document: bytes, name: str) -> Element:
    try:
        root = SafeET.fromstring(document)
    except DefusedXmlException as error:
        raise KmlError(
            f"{name}: the KML uses XML entities or external references, which are not read ({error})"
        ) from error
    except SafeET.ParseError as error:
        raise KmlError(f"{name}: not XML: {error}") from error  # expat's message ends with the line and column
    if _local(root.tag) != "kml":
        raise KmlError(f"{name}: not KML: the document's root element is <{_local(root.tag)}>, not <kml>")
    return root


def _local(tag: str) -> str:
    """An element's name without its namespace: KML 2.2, Google's older 2.0/2.1 and none at all read alike."""
    return tag.rsplit("}", 1)[-1]


def _child(element: Element, local: str) -> Element | None:
    return next((child for child in element if _local(child.tag) == local), None)


def _text(element: Element | None) -> str:
    return " ".join((element.text or "").split()) if element is not None else ""


def _coordinates(point: Element, where: str) -> tuple[float, float]:
    """(lat, lon) of a Point's ``<coordinates>lon,lat[,alt]</coordinates>``."""
    text = _text(_child(point, "coordinates"))
    if not text:
        raise KmlError(f"{where}: its Point has no <coordinates> (expected longitude,latitude[,altitude])")
    tuples = text.split()
    if len(tuples) != 1:
        raise KmlError(f"{where}: its Point has {len(tuples)} coordinate tuples, expected one longitude,latitude")
    try:
        values = [float(part) for part in tuples[0].split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(math.isfinite(value) for value in values):
        raise KmlError(f"{where}: coordinates '{tuples[0]}' are not longitude,latitude[,altitude] in degrees")
    lon, lat = values[0], values[1]
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise KmlError(
            f"{where}: coordinates '{tuples[0]}' are out of range (longitude -180..180 first, then latitude -90..90)"
        )
    return lat, lon


def _extended_data(placemark: Element) -> dict[str, str]:
    """A placemark's ExtendedData fields: ``<Data name><value>`` (Google Earth) and ``<SimpleData name>`` (QGIS)."""
    fields: dict[str, str] = {}
    extended = _child(placemark, "ExtendedData")
    if extended is None:
        return fields
    for element in extended.iter():
        key = element.get("name")
        if key is None:
            continue
        if _local(element.tag) == "Data":
            fields.setdefault(key, _text(_child(element, "value")))
        elif _local(element.tag) == "SimpleData":
            fields.setdefault(key, _text(element))
    return fields


def _facing(value: str | None, where: str) -> float | None:
    if value is None or value == "":
        return None
    try:
        degrees = float(value)
    except ValueError:
        degrees = math.nan
    if not math.isfinite(degrees):
        raise KmlError(f"{where}: facing '{value}' is not a number of degrees")
    return math.radians(degrees)


def _identifier(attribute: str | None, label: str, number: int) -> str:
    """The placemark's id attribute if it is a target id, else a slug of it, of the name, or of its number."""
    if attribute and attribute.isdecimal():
        attribute = None  # a tool's object counter, not a name anyone chose (module docstring)
    if attribute and TARGET_ID.match(attribute):
        return attribute
    return _slug(attribute or "") or _slug(label) or f"placemark-{number}"


def _slug(text: str) -> str:
    """``text`` as letters, digits and dashes: accents dropped, other runs a dash, lower case, at most 56 long
    (room for a ``-10000`` suffix within the 64 of a target id)."""
    ascii_text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    return re.sub(r"[^A-Za-z0-9_]+", "-", ascii_text).strip("-").lower()[:56].strip("-")


def _unique(ident: str, used: set[str]) -> str:
    candidate, n = ident, 1
    while candidate in used:
        n += 1
        candidate = f"{ident[: 64 - len(str(n)) - 1]}-{n}"
    used.add(candidate)
    return candidate
