"""DSA helpers of the Python package (LN 2.9 has dsa_dss1_sign_message and
dsa_dss1_generate_key_pair); signatures are checked with libln's C verifier."""

import ctypes
import os
import stat

import links_and_nodes as ln
import pytest


def c_verify(public_key_file, message, signature):
    libln = ctypes.CDLL("libln.so.1")  # already loaded by links_and_nodes._ln
    verify = libln.ln_dsa_dss1_verify_message_signature
    verify.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint, ctypes.c_char_p, ctypes.c_uint]
    return verify(str(public_key_file).encode(), message, len(message), signature, len(signature))


def test_generate_sign_and_verify(tmp_path):
    pem, pub = tmp_path / "id.pem", tmp_path / "id.pub"
    assert ln.dsa_dss1_generate_key_pair(str(pem), str(pub)) is None
    assert stat.S_IMODE(os.stat(pem).st_mode) == 0o600
    assert pub.read_text().startswith("ssh-dss ")
    signature = ln.dsa_dss1_sign_message(str(pem), b"some bytes\0with a NUL")
    assert isinstance(signature, bytes) and signature[:1] == b"\x30"
    assert c_verify(pub, b"some bytes\0with a NUL", signature) == 0
    assert c_verify(pub, b"some bytes", signature) == -ln.LNE_INVALID_DSA_SIGNATURE


def test_bad_input_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="bytes"):
        ln.dsa_dss1_sign_message(str(tmp_path / "id.pem"), "text, not bytes")
    with pytest.raises(ln.LNError) as missing:
        ln.dsa_dss1_sign_message(str(tmp_path / "none.pem"), b"x")
    assert missing.value.code == ln.LNE_CHECK_ERRNO
    assert "none.pem" in str(missing.value) and "No such file" in str(missing.value)
    with pytest.raises(ln.LNError) as no_dir:
        ln.dsa_dss1_generate_key_pair(str(tmp_path / "no" / "id.pem"), str(tmp_path / "id.pub"))
    assert no_dir.value.code == ln.LNE_CHECK_ERRNO
