"""Targets from KML/KMZ placemarks (relay.inspection.kml): a real KMZ written by simplekml, positions checked against
independent formulas and Vincenty's geodesic, and hostile files (zip bomb, billion laughs, corrupt zips) refused."""

from __future__ import annotations

import io
import math
import struct
import time
import zipfile
from pathlib import Path

import pytest
import simplekml  # type: ignore[import-untyped]  # simplekml ships no type information (no py.typed, no stubs)

from relay.inspection.kml import (
    MAX_PLACEMARKS,
    MAX_UNCOMPRESSED,
    Georeference,
    KmlError,
    targets_from_kml,
    to_map,
)

#: The site's origin: a yard in Zurich (an arbitrary mid-latitude site).
ORIGIN = Georeference(lat=47.3769, lon=8.5417)
STEP = 0.0001  # degrees: ~11 m north, ~7.5 m east at this latitude
NO_GEO_MESSAGE = (
    "site.kmz: KML coordinates are longitude/latitude; add a georeference to robots.yaml "
    "(georeference: {lat: ..., lon: ..., yaw: 0.0}) to place them in the map frame"
)


def metres_per_degree(lat: float) -> tuple[float, float]:
    """(north, east) metres per degree at ``lat`` from the WGS84 series expansions (Wikipedia, "Latitude: Length
    of a degree of latitude / longitude"), independent of the radii of curvature the module uses."""
    phi = math.radians(lat)
    north = 111_132.92 - 559.82 * math.cos(2 * phi) + 1.175 * math.cos(4 * phi) - 0.0023 * math.cos(6 * phi)
    east = 111_412.84 * math.cos(phi) - 93.5 * math.cos(3 * phi) + 0.118 * math.cos(5 * phi)
    return north, east


def vincenty(lat1: float, lon1: float, lat2: float, lon2: float) -> tuple[float, float]:
    """Geodesic distance (m) and forward azimuth (rad, clockwise from north) on WGS84: Vincenty's inverse formula."""
    a, f = 6_378_137.0, 1 / 298.257223563
    b = a * (1 - f)
    big_l = math.radians(lon2 - lon1)
    u1 = math.atan((1 - f) * math.tan(math.radians(lat1)))
    u2 = math.atan((1 - f) * math.tan(math.radians(lat2)))
    su1, cu1, su2, cu2 = math.sin(u1), math.cos(u1), math.sin(u2), math.cos(u2)
    lam = big_l
    for _ in range(200):
        sl, cl = math.sin(lam), math.cos(lam)
        sin_sigma = math.hypot(cu2 * sl, cu1 * su2 - su1 * cu2 * cl)
        if sin_sigma == 0.0:
            return 0.0, 0.0
        cos_sigma = su1 * su2 + cu1 * cu2 * cl
        sigma = math.atan2(sin_sigma, cos_sigma)
        sin_alpha = cu1 * cu2 * sl / sin_sigma
        cos2_alpha = 1 - sin_alpha**2
        cos_2sm = cos_sigma - 2 * su1 * su2 / cos2_alpha if cos2_alpha else 0.0
        c = f / 16 * cos2_alpha * (4 + f * (4 - 3 * cos2_alpha))
        previous = lam
        lam = big_l + (1 - c) * f * sin_alpha * (
            sigma + c * sin_sigma * (cos_2sm + c * cos_sigma * (-1 + 2 * cos_2sm**2))
        )
        if abs(lam - previous) < 1e-13:
            break
    u_sq = cos2_alpha * (a * a - b * b) / (b * b)
    big_a = 1 + u_sq / 16384 * (4096 + u_sq * (-768 + u_sq * (320 - 175 * u_sq)))
    big_b = u_sq / 1024 * (256 + u_sq * (-128 + u_sq * (74 - 47 * u_sq)))
    delta_sigma = (
        big_b
        * sin_sigma
        * (
            cos_2sm
            + big_b
            / 4
            * (
                cos_sigma * (-1 + 2 * cos_2sm**2)
                - big_b / 6 * cos_2sm * (-3 + 4 * sin_sigma**2) * (-3 + 4 * cos_2sm**2)
            )
        )
    )
    distance = b * big_a * (sigma - delta_sigma)
    azimuth = math.atan2(cu2 * math.sin(lam), cu1 * su2 - su1 * cu2 * math.cos(lam))
    return distance, azimuth


def site_kmz(tmp_path: Path) -> bytes:
    """A Google-Earth-style KMZ made by simplekml: three points with ExtendedData, a path and an area."""
    kml = simplekml.Kml(name="Yard inspection")
    folder = kml.newfolder(name="Targets")
    north = folder.newpoint(name="North valve", coords=[(ORIGIN.lon, ORIGIN.lat + STEP)])
    north.extendeddata.newdata(name="kind", value="valve")
    north.extendeddata.newdata(name="facing", value="90")
    east = folder.newpoint(name="East panel", coords=[(ORIGIN.lon + STEP, ORIGIN.lat)])
    east.extendeddata.newdata(name="kind", value="temperature")
    east.extendeddata.newdata(name="facing", value="-45.5")
    gauge = folder.newpoint(name="Gauge (south-west)", coords=[(ORIGIN.lon - STEP, ORIGIN.lat - STEP, 412.0)])
    gauge.extendeddata.newdata(name="kind", value="gas")
    kml.newlinestring(name="Patrol path", coords=[(ORIGIN.lon, ORIGIN.lat), (ORIGIN.lon + STEP, ORIGIN.lat)])
    kml.newpolygon(name="Yard", outerboundaryis=[(ORIGIN.lon, ORIGIN.lat), (ORIGIN.lon + STEP, ORIGIN.lat + STEP)])
    path = tmp_path / "site.kmz"
    kml.savekmz(str(path))
    return path.read_bytes()


def kml_document(placemarks: str, namespace: str = ' xmlns="http://www.opengis.net/kml/2.2"') -> bytes:
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<kml{namespace}><Document>{placemarks}</Document></kml>'.encode()


def point(lon: float, lat: float, name: str = "", attributes: str = "", extra: str = "") -> str:
    named = f"<name>{name}</name>" if name else ""
    return f"<Placemark{attributes}>{named}{extra}<Point><coordinates>{lon},{lat}</coordinates></Point></Placemark>"


def zip_of(entries: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as archive:
        for name, data in entries.items():
            archive.writestr(name, data)
    return buffer.getvalue()


# --- a real KMZ ---------------------------------------------------------------------------------------------------


def test_a_simplekml_kmz_becomes_targets_at_the_expected_map_positions(tmp_path: Path) -> None:
    data = site_kmz(tmp_path)
    assert zipfile.ZipFile(io.BytesIO(data)).namelist() == ["doc.kml"]  # a KMZ as Google Earth writes it
    targets = targets_from_kml(data, "site.kmz", ORIGIN)

    # The path and the area are not targets; the three points are, in file order.
    assert [t.name for t in targets] == ["North valve", "East panel", "Gauge (south-west)"]
    # simplekml writes id="3", id="5", ... from a process-wide counter: the names' slugs are the ids instead.
    assert [t.id for t in targets] == ["north-valve", "east-panel", "gauge-south-west"]
    assert [t.kind for t in targets] == ["valve", "temperature", "gas"]
    assert targets[0].facing == pytest.approx(math.pi / 2)
    assert targets[1].facing == pytest.approx(math.radians(-45.5))
    assert targets[2].facing is None

    per_north, per_east = metres_per_degree(ORIGIN.lat)
    north, east, gauge = targets
    assert north.y == pytest.approx(11.1, abs=0.05)  # 0.0001 deg of latitude is ~11.1 m anywhere
    assert east.x == pytest.approx(math.cos(math.radians(ORIGIN.lat)) * 11.13, abs=0.05)
    assert (north.x, north.y) == pytest.approx((0.0, STEP * per_north), abs=1e-4)
    assert (east.x, east.y) == pytest.approx((STEP * per_east, 0.0), abs=1e-4)
    assert (gauge.x, gauge.y) == pytest.approx((-STEP * per_east, -STEP * per_north), abs=1e-4)


def test_the_map_yaw_turns_the_axes(tmp_path: Path) -> None:
    data = site_kmz(tmp_path)
    per_north, per_east = metres_per_degree(ORIGIN.lat)
    # yaw = pi/2: the map's +x points north, so its +y points west.
    turned = Georeference(ORIGIN.lat, ORIGIN.lon, yaw=math.pi / 2)
    north, east, gauge = targets_from_kml(data, "site.kmz", turned)
    assert (north.x, north.y) == pytest.approx((STEP * per_north, 0.0), abs=1e-4)
    assert (east.x, east.y) == pytest.approx((0.0, -STEP * per_east), abs=1e-4)
    assert (gauge.x, gauge.y) == pytest.approx((-STEP * per_north, STEP * per_east), abs=1e-4)
    # yaw = pi: +x points west.
    (north, east, _) = targets_from_kml(data, "site.kmz", Georeference(ORIGIN.lat, ORIGIN.lon, yaw=math.pi))
    assert (east.x, east.y) == pytest.approx((-STEP * per_east, 0.0), abs=1e-4)
    assert (north.x, north.y) == pytest.approx((0.0, -STEP * per_north), abs=1e-4)


def test_without_a_georeference_the_file_is_refused_with_what_to_add(tmp_path: Path) -> None:
    with pytest.raises(KmlError) as raised:
        targets_from_kml(site_kmz(tmp_path), "site.kmz", None)
    assert str(raised.value) == NO_GEO_MESSAGE


def test_without_a_georeference_a_file_without_points_is_no_error() -> None:
    line = (
        "<Placemark><name>Path</name><LineString><coordinates>8.5,47.3 8.6,47.4</coordinates></LineString></Placemark>"
    )
    assert targets_from_kml(kml_document(line), "paths.kml", None) == []


# --- the projection against the geodesic ---------------------------------------------------------------------------


def projection_error(lat0: float, distance: float) -> float:
    """The largest distance (m) between to_map's position and the geodesic one (Vincenty's distance and azimuth
    from the origin), over 72 directions at ``distance`` metres from an origin at ``lat0``."""
    geo = Georeference(lat0, 10.0)
    per_north, per_east = metres_per_degree(lat0)
    worst = 0.0
    for k in range(72):
        bearing = math.radians(5 * k)
        lat = lat0 + distance * math.cos(bearing) / per_north
        lon = 10.0 + distance * math.sin(bearing) / per_east
        x, y = to_map(geo, lat, lon)
        s, azimuth = vincenty(lat0, 10.0, lat, lon)
        worst = max(worst, math.hypot(x - s * math.sin(azimuth), y - s * math.cos(azimuth)))
    return worst


@pytest.mark.parametrize(("lat0", "bound"), [(0.0, 0.005), (15.0, 0.03), (45.0, 0.1), (60.0, 0.17), (70.0, 0.27)])
def test_the_projection_error_over_a_1_km_site_is_as_documented(lat0: float, bound: float) -> None:
    # The module docstring's figures: 0.02 m at 15 degrees, 0.09 m at 45, 0.16 at 60, 0.25 at 70.
    assert projection_error(lat0, 1000.0) < bound
    assert projection_error(lat0, 100.0) < 0.005  # a building: millimetres
    assert projection_error(-lat0, 1000.0) < bound  # the southern hemisphere mirrors it


def test_the_projection_error_grows_with_the_square_of_the_distance() -> None:
    near, far = projection_error(45.0, 1000.0), projection_error(45.0, 5000.0)
    assert far / near == pytest.approx(25, rel=0.1)
    assert far < 2.5  # MAX_DISTANCE's documented figure


def test_to_map_takes_the_short_way_across_the_antimeridian() -> None:
    geo = Georeference(lat=-16.5, lon=179.9999)
    x, y = to_map(geo, -16.5, -179.9999)
    assert x == pytest.approx(2 * STEP * metres_per_degree(-16.5)[1], abs=1e-4)
    assert y == pytest.approx(0.0, abs=1e-9)


def test_a_georeference_must_be_a_place() -> None:
    for lat, lon, yaw in (
        (95.0, 0.0, 0.0),
        (89.5, 0.0, 0.0),
        (math.nan, 0.0, 0.0),
        (0.0, 200.0, 0.0),
        (0, 0, math.inf),
    ):
        with pytest.raises(ValueError, match="georeference"):
            Georeference(lat, lon, yaw)


# --- plain KML ---------------------------------------------------------------------------------------------------


def test_a_plain_kml_with_ids_duplicates_and_simple_data() -> None:
    schema = (
        '<ExtendedData><SchemaData schemaUrl="#s"><SimpleData name="kind">gas</SimpleData></SchemaData></ExtendedData>'
    )
    placemarks = "".join(
        [
            point(ORIGIN.lon, ORIGIN.lat, "Pump", ' id="pump_1"'),
            point(ORIGIN.lon, ORIGIN.lat, "Tank", extra=schema),
            point(ORIGIN.lon, ORIGIN.lat, "Tank"),
            point(ORIGIN.lon, ORIGIN.lat, "  Tank  "),
            point(ORIGIN.lon, ORIGIN.lat, "Ölfass Nr. 7", ' id="layer.7"'),
            point(ORIGIN.lon, ORIGIN.lat),
            "<Folder><name>Nested</name>" + point(ORIGIN.lon, ORIGIN.lat, "Deep") + "</Folder>",
        ]
    )
    targets = targets_from_kml(kml_document(placemarks), "plant.kml", ORIGIN)
    assert [t.id for t in targets] == ["pump_1", "tank", "tank-2", "tank-3", "layer-7", "placemark-6", "deep"]
    assert [t.name for t in targets] == ["Pump", "Tank", "Tank", "Tank", "Ölfass Nr. 7", "placemark-6", "Deep"]
    assert [t.kind for t in targets] == ["point", "gas", "point", "point", "point", "point", "point"]
    assert all((t.x, t.y) == (0.0, 0.0) for t in targets)


def test_kml_without_a_namespace_and_google_s_old_one_are_read() -> None:
    for namespace in ("", ' xmlns="http://earth.google.com/kml/2.1"'):
        data = kml_document(point(ORIGIN.lon, ORIGIN.lat + STEP, "A"), namespace)
        (target,) = targets_from_kml(data, "old.kml", ORIGIN)
        assert target.y == pytest.approx(STEP * metres_per_degree(ORIGIN.lat)[0], abs=1e-4)


def test_a_kmz_without_doc_kml_uses_its_first_kml() -> None:
    data = zip_of(
        {
            "__MACOSX/._site.kml": b"\x00\x05\x16\x07 not xml",
            "files/photo.jpg": b"\xff\xd8",
            "site.kml": kml_document(point(ORIGIN.lon, ORIGIN.lat, "First")),
            "other.kml": kml_document(point(ORIGIN.lon, ORIGIN.lat, "Second")),
        }
    )
    assert [t.name for t in targets_from_kml(data, "site.kmz", ORIGIN)] == ["First"]


@pytest.mark.parametrize(
    ("coordinates", "problem"),
    [
        ("", "has no <coordinates>"),
        ("8.5", "not longitude,latitude"),
        ("8.5,abc", "not longitude,latitude"),
        ("8.5,47.3,1,2", "not longitude,latitude"),
        ("nan,47.3", "not longitude,latitude"),
        ("47.3,95.0", "out of range"),
        ("8.5,47.3 8.6,47.4", "2 coordinate tuples"),
    ],
)
def test_a_point_with_bad_coordinates_names_the_file_and_the_placemark(coordinates: str, problem: str) -> None:
    data = kml_document(
        f"<Placemark><name>Valve 3</name><Point><coordinates>{coordinates}</coordinates></Point></Placemark>"
    )
    with pytest.raises(KmlError, match=r'^plant\.kml: placemark "Valve 3": .*' + problem):
        targets_from_kml(data, "plant.kml", ORIGIN)


def test_a_bad_facing_names_the_placemark() -> None:
    extra = '<ExtendedData><Data name="facing"><value>north-east</value></Data></ExtendedData>'
    data = kml_document(point(ORIGIN.lon, ORIGIN.lat, "Valve 3", extra=extra))
    with pytest.raises(KmlError, match=r"^plant\.kml: placemark \"Valve 3\": facing 'north-east' is not a number"):
        targets_from_kml(data, "plant.kml", ORIGIN)


def test_a_placemark_far_from_the_georeference_is_refused() -> None:
    swapped = Georeference(lat=ORIGIN.lon, lon=ORIGIN.lat)  # the classic mistake
    data = kml_document(point(ORIGIN.lon, ORIGIN.lat, "Pump"))
    with pytest.raises(KmlError, match=r'placemark "Pump": .* km from the georeference .*swapped'):
        targets_from_kml(data, "plant.kml", swapped)


def test_too_many_placemarks_are_refused() -> None:
    data = kml_document("<Placemark/>" * (MAX_PLACEMARKS + 1))
    with pytest.raises(KmlError, match=rf"^big\.kml: {MAX_PLACEMARKS + 1} placemarks, at most {MAX_PLACEMARKS}"):
        targets_from_kml(data, "big.kml", ORIGIN)


@pytest.mark.parametrize(
    ("data", "problem"),
    [
        (b"", "not XML"),
        (b"hello, world", "not XML"),
        (b"<kml><Document>", "not XML"),
        (b'<svg xmlns="http://www.w3.org/2000/svg"/>', "root element is <svg>"),
    ],
)
def test_what_is_not_kml_is_refused(data: bytes, problem: str) -> None:
    with pytest.raises(KmlError, match=rf"^notes\.kml: .*{problem}"):
        targets_from_kml(data, "notes.kml", ORIGIN)


# --- hostile and damaged files ---------------------------------------------------------------------------------------

BILLION_LAUGHS = b"""<?xml version="1.0"?>
<!DOCTYPE kml [
  <!ENTITY lol "lol">
  <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
  <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
  <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
  <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
  <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
  <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
  <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
  <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
  <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<kml xmlns="http://www.opengis.net/kml/2.2"><Placemark><name>&lol9;</name>
<Point><coordinates>8.5417,47.3769</coordinates></Point></Placemark></kml>
"""

EXTERNAL_ENTITY = b"""<?xml version="1.0"?>
<!DOCTYPE kml [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<kml xmlns="http://www.opengis.net/kml/2.2"><Placemark><name>&secret;</name>
<Point><coordinates>8.5417,47.3769</coordinates></Point></Placemark></kml>
"""


@pytest.mark.parametrize("document", [BILLION_LAUGHS, EXTERNAL_ENTITY], ids=["billion-laughs", "external-entity"])
def test_xml_entities_are_refused_fast(document: bytes) -> None:
    for data, name in ((document, "bomb.kml"), (zip_of({"doc.kml": document}), "bomb.kmz")):
        start = time.thread_time()  # CPU time: a loaded machine makes the clock's longer, not the parser's work
        with pytest.raises(KmlError, match=rf"^{name.replace('.', '[.]')}: the KML uses XML entities"):
            targets_from_kml(data, name, ORIGIN)
        assert time.thread_time() - start < 0.5  # expanded, billion laughs is 3 GB of "lol"


def test_a_zip_bomb_is_refused_before_it_inflates() -> None:
    payload = b" " * (MAX_UNCOMPRESSED + 1)
    data = zip_of({"doc.kml": payload})
    assert len(data) < 100_000  # ~20 KB on the wire
    start = time.thread_time()  # CPU time, as above
    with pytest.raises(KmlError, match=r"^bomb\.kmz: the KMZ holds 20971521 bytes uncompressed, more than 20 MB"):
        targets_from_kml(data, "bomb.kmz", ORIGIN)
    assert time.thread_time() - start < 0.1  # the directory's claim is enough: nothing was inflated


def test_many_small_entries_count_together() -> None:
    chunk = b"\0" * (MAX_UNCOMPRESSED // 4 + 1)
    data = zip_of({"doc.kml": kml_document("")} | {f"files/{i}.bin": chunk for i in range(4)})
    with pytest.raises(KmlError, match=r"uncompressed, more than 20 MB"):
        targets_from_kml(data, "many.kmz", ORIGIN)


def test_a_zip_bomb_that_lies_about_its_size_is_refused() -> None:
    # The same bomb with its size fields patched to claim 1 KB: the directory check passes, inflating must stop.
    data = bytearray(zip_of({"doc.kml": b" " * (MAX_UNCOMPRESSED + 1)}))
    local = data.index(b"PK\x03\x04")
    central = data.index(b"PK\x01\x02")
    struct.pack_into("<I", data, local + 22, 1024)  # local header: uncompressed size
    struct.pack_into("<I", data, central + 24, 1024)  # central directory: uncompressed size
    assert zipfile.ZipFile(io.BytesIO(bytes(data))).infolist()[0].file_size == 1024
    with pytest.raises(KmlError, match=r"^liar\.kmz: "):
        targets_from_kml(bytes(data), "liar.kmz", ORIGIN)


def test_a_corrupt_kmz_is_refused(tmp_path: Path) -> None:
    good = site_kmz(tmp_path)
    truncated = good[: len(good) // 2]
    flipped = bytearray(good)
    start = flipped.index(b"doc.kml") + len(b"doc.kml")  # the deflated document follows its name
    for i in range(start + 20, start + 60):
        flipped[i] ^= 0xFF
    for data in (truncated, bytes(flipped), b"PK\x03\x04 nothing else"):
        with pytest.raises(KmlError, match=r"^site\.kmz: the KMZ \(zip\) archive cannot be read"):
            targets_from_kml(data, "site.kmz", ORIGIN)


def test_a_kmz_that_is_not_a_zip_or_holds_no_kml_is_refused() -> None:
    with pytest.raises(KmlError, match=r"^site\.kmz: not a KMZ \(zip\) archive"):
        targets_from_kml(kml_document(""), "site.kmz", ORIGIN)
    with pytest.raises(KmlError, match=r"^site\.kmz: the KMZ holds no \.kml document"):
        targets_from_kml(zip_of({"files/photo.jpg": b"\xff\xd8"}), "site.kmz", ORIGIN)
    with pytest.raises(KmlError, match=r"^site\.kmz: the KMZ holds no \.kml document"):
        targets_from_kml(zip_of({}), "site.kmz", ORIGIN)


def test_kml_error_is_a_value_error() -> None:
    assert issubclass(KmlError, ValueError)
