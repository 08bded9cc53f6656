"""The bench over a real VISA stack: serve-sim's sockets and ptys, the drivers over pyvisa-py.

Every served bench here listens on 127.0.0.1 and is closed by its `with`; the
`loopback_only` fixture refuses any connection a real backend tries to another address.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import re
import socket
from pathlib import Path

import pandas as pd
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import recorded_traffic
from small_quick import small_quick
from squeezebench import cli, paths
from squeezebench.instruments.bench import sim_bench_config
from squeezebench.instruments.served import served_bench_file
from squeezebench.protocols.campaign import run_campaign
from squeezebench.schemas import stage_travel_mm
from squeezebench.simbench.line import MANUAL_SETTINGS, LineSettings, received
from squeezebench.simbench.serve_sim import ServedSim
from squeezebench.simbench.serve_tcp import TcpPort

pytest.importorskip("pyvisa_py")
pytest.importorskip("serial")

SCENE = paths.input_file("one_column_1mm")
#: What differs by design between a served and an in-process run: the bench's provenance.
PROVENANCE = ["bench", "bench_input", "bench_input_sha256"]


@pytest.fixture(autouse=True)
def loopback_only(monkeypatch):
    """A socket of this test connects to the loopback or is refused before it tries."""
    real_socket = socket.socket

    class LoopbackSocket(real_socket):
        def _check(self, address):
            host = address[0] if isinstance(address, tuple) else address
            try:
                loopback = ipaddress.ip_address(socket.gethostbyname(host)).is_loopback
            except (OSError, ValueError):
                loopback = False
            if not loopback:
                raise PermissionError(f"test refused a connection to {host!r}: loopback only")

        def connect(self, address):
            self._check(address)
            return super().connect(address)

        def connect_ex(self, address):
            self._check(address)
            return super().connect_ex(address)

    monkeypatch.setattr(socket, "socket", LoopbackSocket)


def served_bench(sim: ServedSim, folder: Path) -> Path:
    path = folder / "served.yaml"
    config = sim_bench_config(SCENE)
    path.write_text(yaml.safe_dump(served_bench_file(sim.addresses, config.electronics, stage_travel_mm(config))))
    return path


def rows(run_dir: Path) -> dict[str, pd.DataFrame]:
    return {str(f.relative_to(run_dir)): pd.read_parquet(f).drop(columns=PROVENANCE)
            for f in sorted((run_dir / "measurements").rglob("*.parquet"))}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """quick's kinds of step at half its messages, each of which a served bench carries over
    a socket or a pty."""
    return small_quick(tmp_path_factory.mktemp("campaign"))


@pytest.fixture(scope="module")
def in_process_run(campaign, tmp_path_factory) -> tuple[dict[str, pd.DataFrame], dict[str, list[str]]]:
    """The campaign on the in-process simulated bench: its rows and {role: the messages its
    drivers sent}."""
    folder = tmp_path_factory.mktemp("in_process")
    with recorded_traffic() as traffic:
        run_dir = run_campaign(campaign, out_dir=folder / "run", progress=False)
    return rows(run_dir), traffic


@pytest.fixture(scope="module")
def in_process(in_process_run) -> dict[str, pd.DataFrame]:
    return in_process_run[0]


def test_the_fixture_refuses_a_real_backend_opening_a_lab_address():
    import pyvisa

    resource_manager = pyvisa.ResourceManager("@py")
    try:
        with pytest.raises(Exception, match="loopback only"):
            resource_manager.open_resource("TCPIP::192.168.0.20::5025::SOCKET", open_timeout=500)
    finally:
        resource_manager.close()


def test_serve_sim_listens_on_the_loopback_only():
    with pytest.raises(ValueError, match="loopback only"):
        TcpPort(lambda data: [], host="0.0.0.0")


def test_a_campaign_over_pyvisa_py_has_the_simulated_benchs_rows(campaign, in_process, tmp_path):
    with ServedSim(SCENE, computing_allowance_s=30) as sim:   # a loaded machine computes slowly
        bench = served_bench(sim, tmp_path)
        assert cli.main(["check", "--bench", str(bench), "-q"]) == 0
        served = rows(run_campaign(campaign, out_dir=tmp_path / "run", progress=False, bench_file=bench))
    assert list(served) == list(in_process)
    for name, expected in in_process.items():
        pd.testing.assert_frame_equal(served[name], expected, check_exact=True, obj=name)


def faulty_scene(folder: Path, faults: list[dict]) -> Path:
    path = folder / SCENE.name   # same name: the campaign's plate is this scene's
    path.write_text(SCENE.read_text() + yaml.safe_dump({"transport_faults": faults}))
    return path


def test_replies_in_random_chunks_are_joined_and_change_no_row(campaign, in_process_run, tmp_path):
    in_process, traffic = in_process_run
    scene = faulty_scene(tmp_path, [{"fault": "chunked_reply", "instrument": "scope", "max_chunk_bytes": 50,
                                     "max_pause_s": 1e-4}])
    with ServedSim(scene, computing_allowance_s=30) as sim:
        bench = served_bench(sim, tmp_path)
        served = rows(run_campaign(campaign, out_dir=tmp_path / "run", progress=False, bench_file=bench))
        # every reply of the scope came in pieces: one per query the drivers send it
        assert sim.served.faults[0].seen == sum("?" in message for message in traffic["scope"])
    for name, expected in in_process.items():
        pd.testing.assert_frame_equal(served[name], expected, check_exact=True, obj=name)


@pytest.mark.parametrize("fault, expected", [
    ({"fault": "slow_trickle", "instrument": "scope", "query": "ACQUIRE:MODE?", "occurrence": 90, "bytes_per_s": 0.2},
     r"scope \(TCPIP0?::127\.0\.0\.1::\d+::SOCKET\): no answer to ACQUIRE:MODE\?.* within 2 s"),
    ({"fault": "missing_termination", "instrument": "generator", "query": "VOLT:OFFS?", "occurrence": 20},
     r"generator \(ASRL/dev/pts/\d+::INSTR\): no answer to .*VOLT:OFFS\?.* within"),
    ({"fault": "connection_reset", "instrument": "scope", "query": "CURVE?", "occurrence": 20},
     r"scope \(TCPIP0?::127\.0\.0\.1::\d+::SOCKET\).*(lost|reset).*CURVE\?"),
    ({"fault": "framing_error", "instrument": "generator", "query": "VOLT:OFFS?", "occurrence": 20},
     r"generator \(ASRL/dev/pts/\d+::INSTR\): unexpected reply b?'\\x00.*VOLT:OFFS\?"),
], ids=lambda value: value["fault"] if isinstance(value, dict) else "")
def test_a_transport_fault_stops_with_one_message_and_resume_completes(campaign, in_process, tmp_path, capsys,
                                                                       fault, expected):
    scene = faulty_scene(tmp_path, [fault])
    out = tmp_path / "run"
    with ServedSim(scene) as sim:
        bench = str(served_bench(sim, tmp_path))
        assert cli.main(["run", str(campaign), "--bench", bench, "--out", str(out), "-q"]) == 2
        message = capsys.readouterr().err.strip()
        stored = rows(out)
        assert cli.main(["run", str(campaign), "--bench", bench, "--out", str(out), "--resume", "-q"]) == 0
    assert len(message.splitlines()) == 1, message
    assert re.search(expected, message), message
    assert stored, "the fault came after some steps were stored"
    resumed = rows(out)
    assert list(resumed) == list(in_process)
    for name, frame in stored.items():   # nothing stored was lost or changed by the resume
        pd.testing.assert_frame_equal(resumed[name], frame, check_exact=True, obj=name)


def test_a_client_at_the_wrong_stop_bits_gets_no_answer_from_the_33120a(tmp_path):
    import pyvisa
    from pyvisa import constants

    with ServedSim(SCENE) as sim:
        resource_manager = pyvisa.ResourceManager("@py")
        try:
            generator = resource_manager.open_resource(sim.addresses["generator"], read_termination="\n",
                                                       write_termination="\n", timeout=300)
            generator.baud_rate, generator.stop_bits = 9600, constants.StopBits.one
            with pytest.raises(pyvisa.errors.VisaIOError):
                generator.query("*IDN?")
            generator.stop_bits = constants.StopBits.two   # the manual's setting: it answers
            generator.write("")   # ends the garbled line the 33120A holds
            assert "33120A" in generator.query("*IDN?")
        finally:
            resource_manager.close()


def test_a_served_bench_adds_the_computing_allowance_to_the_drivers_timeouts(tmp_path):
    from pyvisa import constants

    from squeezebench.instruments.bench import open_bench
    from squeezebench.schemas import load_bench_file

    with ServedSim(SCENE, computing_allowance_s=7) as sim:
        with open_bench(load_bench_file(served_bench(sim, tmp_path))) as bench:
            scope = bench.scope.resource
            assert scope.timeout == 2000   # what the driver set, read back
            assert scope.get_visa_attribute(constants.ResourceAttribute.timeout_value) == 9000
            with bench.scope.timeout(5.0):
                assert scope.get_visa_attribute(constants.ResourceAttribute.timeout_value) == 12000
            assert scope.timeout == 2000


def test_serve_sim_writes_a_bench_file_and_stops_by_itself(tmp_path, capsys):
    bench = tmp_path / "served.yaml"
    assert cli.main(["serve-sim", "--scene", "one_column_1mm", "--bench", str(bench), "--for", "0.2"]) == 0
    written = yaml.safe_load(bench.read_text())
    assert written["visa_library"] == "@py"
    assert written["resources"]["scope"].startswith("TCPIP::127.0.0.1::")
    assert all(written["resources"][role].startswith("ASRL/dev/pts/") for role in ("generator", "vibrometer"))
    assert "bench: TCPIP::127.0.0.1::" in capsys.readouterr().out


def test_bad_serve_sim_and_run_bench_arguments_are_one_message(tmp_path, capsys):
    assert cli.main(["serve-sim", "--bench", str(tmp_path / "no" / "dir.yaml"), "--for", "0"]) == 2
    assert "cannot be written" in capsys.readouterr().err
    assert cli.main(["run", "quick", "--bench", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "missing.yaml" in err and "--bench" in err


# -- the line model -------------------------------------------------------------------------
line_settings = st.builds(LineSettings, st.sampled_from([1200, 9600, 57600, 115200]), st.sampled_from([7, 8]),
                          st.sampled_from(["N", "E", "O"]), st.sampled_from([1, 2]))


@settings(max_examples=60, deadline=None)
@given(data=st.binary(min_size=1, max_size=40), settings_=line_settings)
def test_a_receiver_at_the_senders_rate_and_framing_reads_what_was_sent(data, settings_):
    """Sampled bit by bit (the sender's extra stop bit makes the settings differ): every
    data byte comes through, masked to the data bits."""
    mask = (1 << settings_.data_bits) - 1
    two_stop = dataclasses.replace(settings_, stop_bits=2)
    assert received(data, two_stop, dataclasses.replace(settings_, stop_bits=1)) == bytes(b & mask for b in data)
    assert received(data, settings_, settings_) == data


def test_the_wrong_baud_rate_garbles_and_one_stop_bit_short_is_a_framing_error():
    text = b"HEWLETT-PACKARD,33120A\n"
    generator = MANUAL_SETTINGS["generator"]   # 9600 8N2
    assert received(text, generator, LineSettings(115200, 8, "N", 2)) != text
    one_stop = LineSettings(9600, 8, "N", 1)
    # back to back, the second stop bit a receiver checks lands on the next start bit
    assert received(text, one_stop, generator)[0] == 0 and received(text, one_stop, generator) != text
    assert received(text, generator, one_stop) == text   # a receiver checking one stop bit of two is happy


def test_transfer_time_is_frame_bits_over_baud():
    assert MANUAL_SETTINGS["generator"].transfer_s(960) == pytest.approx(960 * 11 / 9600)
    assert MANUAL_SETTINGS["vibrometer"].transfer_s(11520) == pytest.approx(1.0)
