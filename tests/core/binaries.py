"""What a shared library built for another system is: its format, CPU and exported function names, read from the
file's own headers (ELF, PE/COFF, Mach-O), so a machine that cannot run it can still check it."""

from __future__ import annotations

import struct

ELF_MACHINES = {62: "x86_64", 183: "arm64"}
PE_MACHINES = {0x8664: "x86_64", 0xAA64: "arm64"}
MACHO_CPUS = {0x01000007: "x86_64", 0x0100000C: "arm64"}


def describe(data: bytes) -> tuple[str, str, set[str]]:
    """(format, CPU, exported function names) of a 64-bit little-endian shared library; ValueError otherwise."""
    if data[:4] == b"\x7fELF":
        return _elf(data)
    if data[:2] == b"MZ":
        return _pe(data)
    if data[:4] == struct.pack("<I", 0xFEEDFACF):
        return _macho(data)
    raise ValueError("not an ELF, PE or 64-bit Mach-O file")


def _text(data: bytes, offset: int) -> str:
    return data[offset : data.index(b"\0", offset)].decode()


def _elf(data: bytes) -> tuple[str, str, set[str]]:
    if data[4:6] != b"\x02\x01" or struct.unpack_from("<H", data, 16)[0] != 3:  # 64-bit, little-endian, shared
        raise ValueError("not a 64-bit little-endian ELF shared object")
    machine = struct.unpack_from("<H", data, 18)[0]
    section_offset, size, count = (struct.unpack_from("<Q", data, 40)[0], *struct.unpack_from("<HH", data, 58))
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, section_offset + i * size) for i in range(count)]
    names = set()
    for _name, kind, _flags, _address, offset, length, link, _info, _align, entry in sections:
        if kind != 11:  # SHT_DYNSYM
            continue
        strings = sections[link][4]
        for at in range(offset, offset + length, entry):
            name, info, _other, section = struct.unpack_from("<IBBH", data, at)
            if info >> 4 == 1 and info & 0xF == 2 and section != 0:  # global, a function, defined here
                names.add(_text(data, strings + name))
    return "ELF", ELF_MACHINES.get(machine, hex(machine)), names


def _pe(data: bytes) -> tuple[str, str, set[str]]:
    header = struct.unpack_from("<I", data, 0x3C)[0]
    if data[header : header + 4] != b"PE\0\0":
        raise ValueError("no PE signature")
    machine, n_sections = struct.unpack_from("<HH", data, header + 4)
    optional_size, characteristics = struct.unpack_from("<HH", data, header + 20)
    optional = header + 24
    if struct.unpack_from("<H", data, optional)[0] != 0x20B or not characteristics & 0x2000:  # PE32+, a DLL
        raise ValueError("not a 64-bit DLL")
    exports = struct.unpack_from("<I", data, optional + 112)[0]  # data directory 0: the export table's address
    sections = [struct.unpack_from("<8sIIII", data, optional + optional_size + 40 * i) for i in range(n_sections)]

    def offset(address: int) -> int:
        for _name, size, start, raw_size, raw in sections:
            if start <= address < start + max(size, raw_size):
                return raw + address - start
        raise ValueError(f"address {address:#x} is in no section")

    n_names, names_at = struct.unpack_from("<I", data, offset(exports) + 24)[0], offset(exports) + 32
    table = offset(struct.unpack_from("<I", data, names_at)[0])
    names = {_text(data, offset(struct.unpack_from("<I", data, table + 4 * i)[0])) for i in range(n_names)}
    return "PE", PE_MACHINES.get(machine, hex(machine)), names


def _macho(data: bytes) -> tuple[str, str, set[str]]:
    cpu, _subtype, kind, n_commands = struct.unpack_from("<iiII", data, 4)
    if kind != 6:  # MH_DYLIB
        raise ValueError("not a Mach-O dynamic library")
    names, at = set(), 32
    for _ in range(n_commands):
        command, size = struct.unpack_from("<II", data, at)
        if command == 2:  # LC_SYMTAB
            symbols, count, strings, _ = struct.unpack_from("<IIII", data, at + 8)
            for i in range(count):
                name, kind_bits, _section, _description, _value = struct.unpack_from("<IBBHQ", data, symbols + 16 * i)
                if kind_bits & 0xE0 == 0 and kind_bits & 0x0F == 0x0F:  # not debugging; external, in a section
                    names.add(_text(data, strings + name).removeprefix("_"))
        at += size
    return "Mach-O", MACHO_CPUS.get(cpu & 0xFFFFFFFF, hex(cpu)), names
