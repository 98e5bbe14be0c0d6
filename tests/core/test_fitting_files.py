"""FDP files: the add-on's JSON FDP (round trip, strict checks) and XFace's .fdp XML (hand-made and real files)."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from addon.fitting.fdp_file import MAX_BYTES, Fdp, FdpFileError, fdp_text, parse_fdp, read_fdp, write_fdp
from addon.fitting.xface_fdp import XfaceFdpError, parse_xface_fdp, read_xface_fdp
from addon.geometry.face_axes import BLENDER_FACE_AXES
from addon.mpeg4.fapu import Fapu

INTEROP = Path(__file__).resolve().parents[3] / "shared" / "interop" / "fap"
ALICE = INTEROP / "bestdpf_xface-new" / "alice.fdp"
SONG = INTEROP / "thuhcsi_Crystal.TTVS" / "song.fdp"


def sample_fdp() -> Fdp:
    rng = np.random.default_rng(5)
    points = {fp_id: rng.normal(0.0, 0.05, 3) for fp_id in ("2.1", "3.5", "3.6", "9.3", "11.4", "8.3")}
    points["9.3"] = np.array([0.1, 1e-300, -0.30000000000000004])  # awkward floats survive the round trip
    return Fdp(
        feature_points=points,
        texture_coordinates={"3.5": np.array([0.62, 0.55]), "9.3": np.array([0.5, 0.0]), "2.1": np.array([1.0, 0.1])},
        image="textures/face photo.png",
        fapu=Fapu(IRISD0=0.0093, ES0=0.0616, ENS0=0.0426, MNS0=0.0235, MW0=0.0503),
    )


def document(**changes) -> bytes:
    base = json.loads(fdp_text(sample_fdp()))
    base.update(changes)
    return json.dumps({k: v for k, v in base.items() if v is not None}).encode()


def test_write_then_read_gives_the_same_fdp_bit_for_bit(tmp_path):
    fdp = sample_fdp()
    path = tmp_path / "person.fdp.json"
    write_fdp(path, fdp)
    back = read_fdp(path)
    assert list(back.feature_points) == ["2.1", "3.5", "3.6", "8.3", "9.3", "11.4"]  # table order
    for fp_id, point in fdp.feature_points.items():
        np.testing.assert_array_equal(back.feature_points[fp_id], point)
    for fp_id, uv in fdp.texture_coordinates.items():
        np.testing.assert_array_equal(back.texture_coordinates[fp_id], uv)
    assert back.image == fdp.image and back.fapu == fdp.fapu
    assert not list(tmp_path.glob("*.partial"))


def test_a_minimal_fdp_and_its_points_in_blenders_frame():
    fdp = parse_fdp(b'{"format": "mpeg4-face-fdp", "version": 1, "feature_points": {"9.3": [0.01, 0.02, 0.09]}}')
    assert fdp.texture_coordinates == {} and fdp.image is None and fdp.fapu is None
    # MPEG-4 (x left, y up, z forward) -> Blender (x, -z, y)
    np.testing.assert_array_equal(fdp.in_mesh(BLENDER_FACE_AXES)["9.3"], [0.01, -0.09, 0.02])


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"\xff\xfe{}", "not UTF-8"),
        (b'{"version": 1,', "line 1, column .*: not valid JSON"),
        (b'{"version": 1, "version": 1}', "key 'version' appears twice"),
        (
            document(feature_points={"2.1": [0, 0, 0]}).replace(b"[0, 0, 0]", b"[NaN, 0, 0]"),
            "NaN is not a number",
        ),
        (b"[1, 2]", "one JSON object"),
        (document(colour="red"), "unknown key.*'colour'"),
        (document(format="xfdp"), "'format' must be 'mpeg4-face-fdp'"),
        (document(version=2), "version 2; this add-on reads version 1"),
        (document(version=True), "version True"),
        (document(version=1.0), "version 1.0"),
        (document(feature_points={}), "'feature_points' is empty"),
        (document(feature_points={"12.1": [0, 0, 0]}), r"unknown MPEG-4 feature point.*'12\.1'"),
        (document(feature_points={"2.1": [0, 0]}), r"feature_points 2\.1: expected a list of 3 finite numbers"),
        (document(feature_points={"2.1": ["0", 0, 0]}), r"feature_points 2\.1: expected a list of 3"),
        (document(feature_points={"2.1": [True, 0, 0]}), r"feature_points 2\.1: expected a list of 3"),
        (document(feature_points={"2.1": [1e999, 0, 0]}), "line 1, column .*: Infinity is not a number"),
        (document(texture_coordinates={"3.5": [1.2, 0.5]}), r"outside the image \[0, 1\]: 3\.5 \[1\.2, 0\.5\]"),
        (document(texture_coordinates={"4.1": [0.2, 0.5]}), r"texture_coordinates for FPs without a position: 4\.1"),
        (document(image=""), "'image' must be a non-empty path"),
        (document(image="a\nb.png"), "'image' must be a non-empty path without control"),
        (document(image=3), "'image' must be"),
        (document(fapu={"ES0": 0.06}), "'fapu' must give exactly"),
        (
            document(fapu={"IRISD0": 0.01, "ES0": -0.06, "ENS0": 0.04, "MNS0": 0.02, "MW0": 0.05}),
            "ES0 must be positive",
        ),
    ],
)
def test_a_bad_fdp_is_refused_naming_the_item(data, message):
    with pytest.raises(FdpFileError, match=message):
        parse_fdp(data, "person.fdp.json")


def test_size_cap_and_unreadable_files(tmp_path):
    big = tmp_path / "big.json"
    big.write_bytes(b" " * (MAX_BYTES + 1))
    with pytest.raises(FdpFileError, match=f"big.json: larger than {MAX_BYTES} bytes"):
        read_fdp(big)
    with pytest.raises(FdpFileError, match="missing.json: cannot read"):
        read_fdp(tmp_path / "missing.json")


def test_the_writer_checks_first_and_keeps_the_old_file(tmp_path):
    path = tmp_path / "person.fdp.json"
    write_fdp(path, sample_fdp())
    before = path.read_bytes()
    bad = Fdp(feature_points={"2.1": np.array([np.nan, 0.0, 0.0])})
    with pytest.raises(FdpFileError, match=r"feature_points 2\.1: expected a list of 3 finite"):
        write_fdp(path, bad)
    with pytest.raises(FdpFileError, match=r"unknown MPEG-4 feature point.*'99\.9'"):
        write_fdp(path, Fdp(feature_points={"99.9": np.zeros(3)}))
    assert path.read_bytes() == before
    assert not list(tmp_path.glob("*.partial"))


# --- XFace .fdp --------------------------------------------------------------------------------------

XFACE_SAMPLE = b"""<?xml version="1.0" encoding="UTF-8"?>
<xfdp>
  <head>
    <file version="0.2"/>
    <model fdpcount="3"/>
    <fapu ES0="64" IRISD0="12.5" ENS0="48" MNS0="28" MW0="46"/>
    <translation x="1" y="-2" z="-500"/>
    <rotation axis_x="0" axis_y="0" axis_z="2" axis_angle="1.5707963267948966"/>
  </head>
  <source>
    <entity alias="Rest" category="Expression">
      <mesh file="head.wrl" format="wrl"/>
      <bind item="LeftEye" submesh="head.wrl_1" pivotX="30" pivotY="-30" pivotZ="-25"/>
      <bind item="RightEye" submesh="head.wrl_2" pivotX="-30" pivotY="-30" pivotZ="-25"/>
      <bind item="LowerTeeth" submesh="head.wrl_4"/>
      <bind item="Tongue" submesh="head.wrl_5"/>
    </entity>
    <entity alias="aah" category="Viseme"><mesh file="head_aah.wrl" format="wrl"/></entity>
  </source>
  <fdp name="2.1" index="17" affects="head.wrl_0">
    <indices>17 18 19 40 </indices>
    <influence fap="2" type="RaisedCosInfluenceSph" weight="0.3"/>
    <influence fap="15" type="RaisedCosInfluenceWaveY" weight="-0.1"/>
  </fdp>
  <fdp name="2.1" index="3" affects="head.wrl_4">
    <indices>1 2 3</indices>
    <influence fap="2" type="RaisedCosInfluenceSph" weight="1"/>
  </fdp>
  <fdp name="3.5" index="0" affects="head.wrl_1"/>
</xfdp>
"""


def test_a_hand_made_xface_fdp():
    fdp = parse_xface_fdp(XFACE_SAMPLE, "sample.fdp")
    assert fdp.version == "0.2" and fdp.model_fdp_count == 3
    assert fdp.fapu == Fapu(IRISD0=12.5, ES0=64.0, ENS0=48.0, MNS0=28.0, MW0=46.0)  # FAPU0, model units
    np.testing.assert_array_equal(fdp.translation, [1.0, -2.0, -500.0])
    np.testing.assert_allclose(fdp.rotation_matrix(), [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    assert [(e.alias, e.category, e.meshes) for e in fdp.entities] == [
        ("Rest", "Expression", (("head.wrl", "wrl"),)),
        ("aah", "Viseme", (("head_aah.wrl", "wrl"),)),
    ]
    assert [(b.item, b.submesh) for b in fdp.binds] == [
        ("LeftEye", "head.wrl_1"),
        ("RightEye", "head.wrl_2"),
        ("LowerTeeth", "head.wrl_4"),
        ("Tongue", "head.wrl_5"),
    ]
    pivots = fdp.pivots()
    assert set(pivots) == {"LeftEye", "RightEye"}
    np.testing.assert_array_equal(pivots["RightEye"], [-30.0, -30.0, -25.0])
    assert fdp.fp_ids == ("2.1", "3.5")
    chin, teeth, pupil = fdp.feature_points
    assert (chin.mesh, chin.control_vertex, chin.zone.tolist()) == ("head.wrl_0", 17, [17, 18, 19, 40])
    # the file's fap is 0-based: 2 -> FAP 3 (open_jaw), 15 -> FAP 16 (push_b_lip)
    assert [(i.fap, i.kind, i.weight) for i in chin.influences] == [
        (3, "RaisedCosInfluenceSph", 0.3),
        (16, "RaisedCosInfluenceWaveY", -0.1),
    ]
    assert (teeth.mesh, teeth.zone.tolist()) == ("head.wrl_4", [1, 2, 3])
    assert (pupil.zone.size, pupil.influences) == (0, ())


BILLION_LAUGHS = b"""<?xml version="1.0"?>
<!DOCTYPE xfdp [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;">]>
<xfdp><head><file version="0.2"/></head><source/></xfdp>"""


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (BILLION_LAUGHS, "DOCTYPE and ENTITY declarations are not accepted"),
        (b'<?xml version="1.0"?><!doctype xfdp SYSTEM "x.dtd"><xfdp/>', "DOCTYPE and ENTITY"),
        (b"<xfdp><head>", "not well-formed XML at line 1"),
        (b"<fdp/>", "root element <fdp>, expected <xfdp>"),
        (XFACE_SAMPLE.replace(b'version="0.2"', b'version="0.1"'), "file version='0.1'"),
        (XFACE_SAMPLE.replace(b"<source>", b"<source/><source>"), "exactly one <source>, found 2"),
        (XFACE_SAMPLE.replace(b'name="3.5"', b'name="12.1"'), r"<fdp name='12\.1' .*not an MPEG-4 feature point"),
        (
            XFACE_SAMPLE.replace(b'fap="15"', b'fap="68"'),
            r"<fdp name='2\.1' affects='head\.wrl_0'>: <influence fap='68'",
        ),
        (XFACE_SAMPLE.replace(b"WaveY", b"WaveQ"), "unknown influence type 'RaisedCosInfluenceWaveQ'"),
        (XFACE_SAMPLE.replace(b'index="17"', b'index="70000"'), r"index='70000'> must be an integer in 0\.\.65535"),
        (XFACE_SAMPLE.replace(b"17 18 19 40", b"17 18 -19"), r"<indices> must be vertex numbers"),
        (XFACE_SAMPLE.replace(b'affects="head.wrl_4"', b'affects="head.wrl_0"'), "listed twice"),
        (XFACE_SAMPLE.replace(b'ES0="64"', b'ES0="-64"'), "<fapu> values must be positive"),
        (XFACE_SAMPLE.replace(b'x="1"', b'x="nan"'), r"<translation x='nan'> is not a finite number"),
        (XFACE_SAMPLE.replace(b'axis_z="2"', b'axis_z="0"'), "about a zero axis"),
        (
            XFACE_SAMPLE.replace(
                b' pivotY="-30" pivotZ="-25"/>\n      <bind item="RightEye"', b'/>\n<bind item="RightEye"'
            ),
            "gives only pivotX",
        ),
    ],
)
def test_a_bad_xface_fdp_is_refused_naming_the_element(data, message):
    with pytest.raises(XfaceFdpError, match=message):
        parse_xface_fdp(data, "sample.fdp")


def test_an_oversized_xface_fdp_is_refused_unread(tmp_path):
    from addon.fitting.xface_fdp import MAX_BYTES as XFACE_MAX

    big = tmp_path / "big.fdp"
    with open(big, "wb") as stream:
        stream.truncate(XFACE_MAX + 1)
    with pytest.raises(XfaceFdpError, match="larger than"):
        read_xface_fdp(big)


@pytest.mark.skipif(not ALICE.is_file(), reason="the shared interop files are absent")
def test_xface_alice():
    fdp = read_xface_fdp(ALICE)
    assert fdp.fapu == Fapu(IRISD0=16.0, ES0=69.0, ENS0=51.0, MNS0=30.0, MW0=50.0)
    np.testing.assert_array_equal(fdp.translation, [0.0, -1.0, -659.0])
    np.testing.assert_array_equal(fdp.rotation_axis, [-0.999632, -0.0154467, 0.0223226])
    assert fdp.rotation_angle == 0.407589
    assert len(fdp.entities) == 29 and fdp.entities[3].alias == "Rest"
    assert [b.item for b in fdp.binds] == ["Hair", "LeftEye", "RightEye", "LowerTeeth", "UpperTeeth", "Tongue"]
    np.testing.assert_array_equal(fdp.pivots()["LeftEye"], [-33.8, -33.2, -28.8])
    np.testing.assert_array_equal(fdp.pivots()["RightEye"], [33.8, -33.2, -28.8])
    assert len(fdp.feature_points) == 35 and len(fdp.fp_ids) == 33
    chin = fdp.feature_points[0]
    assert (chin.fp_id, chin.mesh, chin.control_vertex, chin.zone.size) == ("2.1", "alice.wrl_3", 2395, 214)
    assert [(i.fap, i.kind, i.weight) for i in chin.influences] == [(3, "RaisedCosInfluenceSph", 0.3)]
    assert {p.mesh for p in fdp.feature_points} == {"alice.wrl_1", "alice.wrl_3", "alice.wrl_5"}
    rotation = fdp.rotation_matrix()
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)


@pytest.mark.skipif(not SONG.is_file(), reason="the shared interop files are absent")
def test_xface_song():
    fdp = read_xface_fdp(SONG)
    assert fdp.model_fdp_count == 51 and len(fdp.feature_points) == 53 and len(fdp.fp_ids) == 45
    assert fdp.fapu == Fapu(IRISD0=5.66434, ES0=35.3143, ENS0=25.5803, MNS0=13.9485, MW0=24.9496)
    np.testing.assert_array_equal(fdp.translation, [0.0, 0.0, -2500.0])
    np.testing.assert_array_equal(fdp.rotation_matrix(), np.eye(3))
    assert fdp.binds == () and [e.alias for e in fdp.entities] == ["Rest"]
    lower_lip = next(p for p in fdp.feature_points if (p.fp_id, p.mesh) == ("2.3", "song_head-FACES"))
    assert lower_lip.control_vertex == 513
    assert [(i.fap, i.weight) for i in lower_lip.influences] == [(16, -0.1), (5, 0.25)]  # push_b_lip reversed
    assert {p.mesh for p in fdp.feature_points if p.fp_id == "2.1"} == {"song_head-FACES", "song_teeth_lower-FACES"}


@pytest.mark.parametrize("reader", ["fdp", "xface"])
def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path, reader):
    from addon.fitting.fdp_file import FdpFileError, read_fdp
    from addon.fitting.xface_fdp import XfaceFdpError, read_xface_fdp

    fifo = tmp_path / "face.fdp"
    os.mkfifo(fifo)
    read, error = (read_fdp, FdpFileError) if reader == "fdp" else (read_xface_fdp, XfaceFdpError)
    with pytest.raises(error, match="face.fdp: not a regular file but a named pipe"):
        read(fifo)
