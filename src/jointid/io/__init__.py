"""jointid.io: file formats (UFF58, CSV), atomic files and the output-directory writer (:mod:`.output_dir`)."""
