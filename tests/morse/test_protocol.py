"""MORSE request lines and reply lines (reference/morse-protocol.md section 2), without sockets."""

from __future__ import annotations

import json

from hypothesis import given
from hypothesis import strategies as st

from vilma.morse import protocol as p

token = st.text(st.characters(min_codepoint=33, max_codepoint=126), min_size=1, max_size=20)
scalars = st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=False, allow_infinity=False), st.booleans(),
                    st.text(max_size=10), st.none())


def test_request_forms_of_the_contract():
    assert p.parse_request("0 simulation details []") == p.Request("0", "simulation", "details", ())
    assert p.parse_request("req1 simulation list_robots\r") == p.Request("req1", "simulation", "list_robots", ())
    assert p.parse_request("id2 atrv.pose get_local_data ") == p.Request("id2", "atrv.pose", "get_local_data", ())
    assert p.parse_request('1 simulation get_stream_port ["robot.pose"]') == p.Request(
        "1", "simulation", "get_stream_port", ("robot.pose",))
    assert p.parse_request("id vilma steer [1,0.3]") == p.Request("id", "vilma", "steer", (1, 0.3))
    assert p.parse_request("c1 cancel") == p.Cancel("c1")
    assert p.parse_request("lonely") == p.Invalid("lonely", "Malformed request! ")
    assert p.parse_request("   ") is None


def test_bad_parameters_are_invalid_with_morse_text():
    bad = p.parse_request("5 vilma steer [1,")
    assert isinstance(bad, p.Invalid) and bad.id == "5"
    assert bad.message.startswith("Invalid request syntax: error while parsing the parameters: <[1,>.")
    obj = p.parse_request('6 vilma steer {"a": 1}')
    assert isinstance(obj, p.Invalid) and "JSON array" in obj.message
    two = p.parse_request("7 vilma")
    assert isinstance(two, p.Invalid) and two.id == "7"


def test_reply_lines_drop_falsy_results_and_end_in_newline():
    assert p.format_reply("3", p.SUCCESS) == b"3 SUCCESS\n"
    for falsy in (None, 0, False, [], {}, ""):
        assert p.format_reply("7", p.SUCCESS, falsy) == b"7 SUCCESS\n"
    assert p.format_reply("1", p.SUCCESS, 60000) == b"1 SUCCESS 60000\n"
    assert p.format_reply("16", p.SUCCESS, "Objects restored to initial position") == \
        b'16 SUCCESS "Objects restored to initial position"\n'
    assert p.format_reply("c1", p.PREEMPTED) == b"c1 PREEMPTED\n"


def test_wrong_count_text_is_what_pymorse_turns_into_type_error():
    assert "wrong # of parameters" in p.wrong_count("steer", ("Steering", "steeringAmount"), 1)


@given(st.text(max_size=200))
def test_any_text_parses_to_a_request_a_cancel_an_error_or_nothing(text):
    r = p.parse_request(text)
    assert r is None or isinstance(r, p.Request | p.Cancel | p.Invalid)
    if isinstance(r, p.Invalid):
        assert "\n" not in p.format_reply(r.id, p.FAILED, r.message)[:-1].decode()


@given(token, token, token.filter(lambda s: s != "cancel"), st.lists(scalars, min_size=1, max_size=5))
def test_requests_round_trip(rid, component, service, params):
    line = f"{rid} {component} {service} {json.dumps(params)}"
    assert p.parse_request(line) == p.Request(rid, component, service, tuple(params))


@given(st.lists(st.binary(max_size=40).map(lambda b: b.replace(b"\n", b"")), max_size=20),
       st.lists(st.integers(1, 30), min_size=1, max_size=10))
def test_line_buffer_reassembles_any_chunking(lines, cuts):
    data = b"".join(line + b"\n" for line in lines)
    buf, out, i, k = p.LineBuffer(), [], 0, 0
    while i < len(data):
        n = cuts[k % len(cuts)]
        out += buf.feed(data[i:i + n])
        i, k = i + n, k + 1
    assert out == lines and buf.pending == 0


@given(st.integers(1, 5000), st.integers(1, 997))
def test_line_buffer_memory_is_bounded_by_the_longest_line(length, chunk):
    buf = p.LineBuffer(max_line=100)
    data = b"x" * length + b"\n" + b"ok\n"
    out = []
    for i in range(0, len(data), chunk):
        out += buf.feed(data[i:i + chunk])
        assert buf.pending <= 100
    if length > 100:
        assert len(out) == 2 and isinstance(out[0], p.TooLong) and out[1] == b"ok"
    else:
        assert out == [b"x" * length, b"ok"]


def test_the_last_line_without_a_newline_ends_the_stream():
    buf = p.LineBuffer(max_line=10)
    assert buf.feed(b"a\nb c") == [b"a"]
    assert buf.end() == [b"b c"] and buf.pending == 0
    assert buf.end() == []  # nothing after it
    assert [type(x) for x in buf.feed(b"x" * 15)] == [p.TooLong]
    buf.feed(b"yyy")
    assert buf.end() == []  # the rest of a line already refused as too long is no line
