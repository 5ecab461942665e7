# `camlab calibrate --corners` on datasets camlab has never seen:
# corners.vnl and truth models made by mrcal's own Python (tests/calib_eval, its README),
# checked against the truth (projection over the central 80% of the imager, FOV, fx) and
# against camlab's documented warnings. The quick subset (7 cases, about 10 s) generates its
# data into the build tree at test time; the full table is tests/calib_eval/run_cases.py.
# Skips (exit 77) when /usr/bin/python3 is missing or has no mrcal (Debian python3-mrcal).
add_test(NAME calib_mrcal_datasets
  COMMAND sh -c "[ -x /usr/bin/python3 ] || { echo 'no /usr/bin/python3: skipped'; exit 77; }; exec /usr/bin/python3 -B \"$@\"" sh
          ${PROJECT_SOURCE_DIR}/tests/calib_eval/run_cases.py
          ${CMAKE_CURRENT_BINARY_DIR}/calib_mrcal_datasets
          --generate --subset quick --camlab $<TARGET_FILE:camlab_cli>)
set_tests_properties(calib_mrcal_datasets PROPERTIES
  SKIP_RETURN_CODE 77
  LABELS stability
  TIMEOUT 300
  COST 21)  # seconds under ctest -j3 on 2 cores, as tests/suite_costs.txt
