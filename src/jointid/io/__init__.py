"""jointid.io: file formats (UFF58, CSV) and atomic output."""
