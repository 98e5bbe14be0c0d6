"""The MPEG-4 Face Animation core: tables, FAPU, FAP streams and FAP -> feature point decoding (no bpy)."""
