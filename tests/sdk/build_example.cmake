# cmake -DSOURCE=examples -DBUILD=dir -DPREFIX=prefix -DGENERATOR=Ninja -DLAUNCHER=... -DTOOLCHAIN=... -P build_example.cmake
# Configures and builds the example project against the installed ddsnav in PREFIX, nothing else.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE} -B ${BUILD} -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release
                        -DCMAKE_PREFIX_PATH=${PREFIX} ${LAUNCHER} ${TOOLCHAIN} COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BUILD} -j 2 COMMAND_ERROR_IS_FATAL ANY)
