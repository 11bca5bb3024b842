# Fetches three.js's browser build (build/three.min.js, a classic script: it loads from file://,
# where module scripts may not) and its licence from the npm registry, for the interactive figures
# (posekit/viewers/web_viewer.h). Run at build time: cmake -DNPM=... -DVERSION=... -DOUT_DIR=... -P this.
# Never committed: the build fetches it, the install copies it to share/posekit.
set(work "${OUT_DIR}/three-${VERSION}")
file(MAKE_DIRECTORY "${work}")
execute_process(COMMAND "${NPM}" pack "three@${VERSION}" --silent --pack-destination "${work}"
                RESULT_VARIABLE failed OUTPUT_QUIET ERROR_VARIABLE why TIMEOUT 300)
if(failed OR NOT EXISTS "${work}/three-${VERSION}.tgz")
  message(WARNING "three.js ${VERSION} could not be fetched from npm (${why}): the report and view --html will have no interactive figures")
  return()
endif()
file(ARCHIVE_EXTRACT INPUT "${work}/three-${VERSION}.tgz" DESTINATION "${work}" PATTERNS package/build/three.min.js package/LICENSE)
file(COPY_FILE "${work}/package/build/three.min.js" "${OUT_DIR}/three.min.js")
file(COPY_FILE "${work}/package/LICENSE" "${OUT_DIR}/three.LICENSE")
file(REMOVE_RECURSE "${work}")
