# ddsnav_add_messages(<target> IDL <file.idl>... [DEPENDS ddsnav::msgs | <other message target>...])
#
# Message types of your own, next to the stock ones (docs/sdk.md). Builds the shared library <target>:
#   - C++ classes from fastddsgen, included as <target>/<file>.h, and <target>/messages.hpp with all of
#     them, usable with bus.publisher<T>/subscribe<T>/inbox<T> like any stock message;
#   - the idlc descriptors of the same types, so Cyclone DDS carries them too;
#   - a registration of every struct with the bus's type registry (raw API, ddsnav echo/record/play) and its
#     OMG IDL schema (the recorder stores it in the MCAP file).
# A process that does not link <target> (the stock `ddsnav record`, `ddsnav play`, `ddsnav echo`) learns
# the types from DDSNAV_MESSAGE_LIBRARIES=/path/lib<target>.so[:...].
#
# The IDL is compiled when CMake configures (and again whenever a file changes): an IDL that does not
# parse, or a type whose name is taken by a stock type, stops the configure step with the file and type.
#
# An IDL file may #include the stock files ("perception.idl", "common.idl", ...) with DEPENDS ddsnav::msgs,
# and the files of another message target named in DEPENDS.

set(_ddsnav_messages_dir ${CMAKE_CURRENT_LIST_DIR})

# Appends to `out_var` the text of `file` with the files it includes first (each once, as the recorder's
# schemas need them: one self-contained text), without the #include lines.
function(_ddsnav_flatten_idl file include_dirs seen_var out_var)
  set(seen ${${seen_var}})
  set(out "${${out_var}}")
  if(file IN_LIST seen)
    return()
  endif()
  list(APPEND seen ${file})
  file(STRINGS ${file} lines)
  file(READ ${file} text)
  string(REGEX MATCHALL "#include[ \t]+\"[^\"]+\"" includes "${text}")
  foreach(include ${includes})
    string(REGEX REPLACE "#include[ \t]+\"([^\"]+)\"" "\\1" name "${include}")
    set(found "")
    get_filename_component(here ${file} DIRECTORY)
    foreach(dir ${here} ${include_dirs})
      if(NOT found AND EXISTS ${dir}/${name})
        set(found ${dir}/${name})
      endif()
    endforeach()
    if(NOT found)
      message(FATAL_ERROR "ddsnav_add_messages: ${file} includes \"${name}\", which is in none of: ${here};${include_dirs}"
                          " (a stock file needs DEPENDS ddsnav::msgs)")
    endif()
    _ddsnav_flatten_idl(${found} "${include_dirs}" seen out)
  endforeach()
  get_filename_component(name ${file} NAME)
  string(REGEX REPLACE "#include[ \t]+\"[^\"]+\"[^\n]*\n" "" body "${text}")
  string(APPEND out "// ${name}\n${body}")
  set(${seen_var} ${seen} PARENT_SCOPE)
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

function(ddsnav_add_messages target)
  cmake_parse_arguments(arg "" "" "IDL;DEPENDS" ${ARGN})
  if(NOT arg_IDL)
    message(FATAL_ERROR "ddsnav_add_messages(${target}): no IDL files given (IDL file.idl...)")
  endif()
  find_program(DDSNAV_FASTDDSGEN fastddsgen REQUIRED)
  find_program(DDSNAV_IDLC idlc REQUIRED)

  # Where included IDL files, their C++ headers and their idlc headers are.
  set(idl_dirs "")
  set(cxx_dirs "")
  set(c_dirs "")
  set(link "")
  foreach(dep ${arg_DEPENDS})
    if(dep STREQUAL "ddsnav::msgs" OR dep STREQUAL "ddsnav_msgs")
      list(APPEND idl_dirs ${DDSNAV_IDL_DIR})
      list(APPEND c_dirs ${DDSNAV_CYCLONE_INCLUDE_DIR})
      # fastddsgen writes #include "perception.h" for an included perception.idl.
      get_target_property(msg_dirs ddsnav::msgs INTERFACE_INCLUDE_DIRECTORIES)
      foreach(dir ${msg_dirs})
        string(REGEX REPLACE "^\\$<(BUILD|INSTALL)_INTERFACE:(.*)>$" "\\2" plain "${dir}")
        # In the build tree fastddsgen writes them only at build time: the folder is known by its name.
        if(EXISTS ${plain}/ddsnav/msg/common.h OR plain MATCHES "/idl/gen/fastdds$")
          list(APPEND cxx_dirs ${plain}/ddsnav/msg)
        endif()
      endforeach()
    elseif(TARGET ${dep})
      get_target_property(dep_idl ${dep} DDSNAV_IDL_DIRS)
      get_target_property(dep_c ${dep} DDSNAV_C_INCLUDE_DIRS)
      get_target_property(dep_cxx ${dep} DDSNAV_CXX_INCLUDE_DIRS)
      list(APPEND idl_dirs ${dep_idl})
      list(APPEND c_dirs ${dep_c})
      list(APPEND cxx_dirs ${dep_cxx})
    else()
      message(FATAL_ERROR "ddsnav_add_messages(${target}): DEPENDS ${dep} is neither ddsnav::msgs nor a message target")
    endif()
    list(APPEND link ${dep})
  endforeach()
  list(APPEND link ddsnav::msgs)
  list(REMOVE_DUPLICATES link)

  set(gen ${CMAKE_CURRENT_BINARY_DIR}/${target}_messages)
  set(cxx_out ${gen}/include/${target})
  set(c_out ${gen}/cyclone)
  file(MAKE_DIRECTORY ${cxx_out} ${c_out} ${gen}/fastddsgen)

  set(idl_files "")
  foreach(idl ${arg_IDL})
    get_filename_component(idl ${idl} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
    if(NOT EXISTS ${idl})
      message(FATAL_ERROR "ddsnav_add_messages(${target}): IDL file ${idl} does not exist")
    endif()
    list(APPEND idl_files ${idl})
    get_filename_component(dir ${idl} DIRECTORY)
    list(APPEND idl_dirs ${dir})
  endforeach()
  list(REMOVE_DUPLICATES idl_dirs)
  set(include_flags "")
  foreach(dir ${idl_dirs})
    list(APPEND include_flags -I ${dir})
  endforeach()

  # The stock type names, to refuse a user type that would shadow one.
  file(GLOB stock_idl ${DDSNAV_IDL_DIR}/*.idl)
  set(stock_types "")
  foreach(f ${stock_idl})
    file(READ ${f} text)
    string(REGEX MATCHALL "struct[ \t]+[A-Za-z0-9_]+[ \t]*{" structs "${text}")
    foreach(s ${structs})
      string(REGEX REPLACE "struct[ \t]+([A-Za-z0-9_]+).*" "ddsnav::msg::\\1" name "${s}")
      list(APPEND stock_types ${name})
      set(stock_file_${name} ${f})
    endforeach()
  endforeach()

  set(cxx_sources "")
  set(c_sources "")
  set(headers "")
  set(types "")        # qualified names
  set(configure_deps "")
  set(schema_defs "")
  set(index 0)
  foreach(idl ${idl_files})
    get_filename_component(name ${idl} NAME_WE)
    # idlc first: its errors name the file, line and column.
    execute_process(COMMAND ${DDSNAV_IDLC} -x final ${include_flags} -o ${c_out} ${idl}
                    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    if(NOT rc EQUAL 0)
      message(FATAL_ERROR "ddsnav_add_messages(${target}): ${idl} does not parse:\n${out}${err}")
    endif()
    execute_process(COMMAND ${DDSNAV_FASTDDSGEN} -replace -cs -t ${gen}/fastddsgen -d ${gen}/fastddsgen ${include_flags} ${idl}
                    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    if(NOT rc EQUAL 0)
      message(FATAL_ERROR "ddsnav_add_messages(${target}): fastddsgen cannot compile ${idl}:\n${out}${err}")
    endif()
    # fastddsgen also writes classes for the included files; only this file's belong to the target.
    configure_file(${gen}/fastddsgen/${name}.h ${cxx_out}/${name}.h COPYONLY)
    configure_file(${gen}/fastddsgen/${name}.cxx ${gen}/${name}.cxx COPYONLY)
    list(APPEND cxx_sources ${gen}/${name}.cxx)
    list(APPEND c_sources ${c_out}/${name}.c)
    list(APPEND headers ${name}.h)

    set(seen "")
    set(schema "")
    _ddsnav_flatten_idl(${idl} "${idl_dirs}" seen schema)
    list(APPEND configure_deps ${seen})
    string(APPEND schema_defs "const char kSchema${index}[] = R\"ddsnavidl(${schema})ddsnavidl\";\n")

    # Each descriptor idlc wrote: `const dds_topic_descriptor_t <symbol> = { ... .m_typename = "<name>"`.
    file(READ ${c_out}/${name}.c c_text)
    string(REGEX MATCHALL "const dds_topic_descriptor_t [A-Za-z0-9_]+ =[^}]*\\.m_typename = \"[A-Za-z0-9_:]+\"" descs "${c_text}")
    foreach(d ${descs})
      string(REGEX REPLACE "const dds_topic_descriptor_t ([A-Za-z0-9_]+) =.*" "\\1" symbol "${d}")
      string(REGEX REPLACE ".*\\.m_typename = \"([A-Za-z0-9_:]+)\"" "\\1" type "${d}")
      if(type IN_LIST stock_types)
        message(FATAL_ERROR "ddsnav_add_messages(${target}): type ${type} in ${idl} has the name of a stock type "
                            "(${stock_file_${type}}); put your types in a module of your own")
      endif()
      if(type IN_LIST types)
        message(FATAL_ERROR "ddsnav_add_messages(${target}): type ${type} is defined twice (again in ${idl})")
      endif()
      list(APPEND types ${type})
      set(symbol_${type} ${symbol})
      set(schema_${type} kSchema${index})
    endforeach()
    math(EXPR index "${index} + 1")
  endforeach()
  if(NOT types)
    message(FATAL_ERROR "ddsnav_add_messages(${target}): no struct in ${idl_files}")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${configure_deps})

  # <target>/messages.hpp: the classes and their type support, as <ddsnav/msg/messages.hpp> for the stock ones.
  set(hpp "// Generated by ddsnav_add_messages(${target}): its message classes.\n#pragma once\n")
  foreach(h ${headers})
    string(APPEND hpp "#include <${target}/${h}>\n")
  endforeach()
  string(APPEND hpp "#include <ddsnav/msg/messages.hpp>\n\nnamespace ddsnav::msg {\n")
  string(CONCAT cpp "// Generated by ddsnav_add_messages(${target}): type support and registration.\n"
          "#include <${target}/messages.hpp>\n#include <ddsnav/msg/make_type_support.hpp>\n#include <ddsnav/msg/registry.hpp>\n\n"
          "struct dds_topic_descriptor;\n")
  set(list_entries "")
  foreach(type ${types})
    string(APPEND hpp "template <> struct IsMessage<::${type}> : std::true_type {};\n"
                      "template <> const TypeSupport& type_support<::${type}>();\n")
    string(APPEND cpp "extern \"C\" const dds_topic_descriptor ${symbol_${type}};\n")
    string(APPEND list_entries "    {&type_support<::${type}>(), ${schema_${type}}},\n")
  endforeach()
  string(APPEND hpp "}  // namespace ddsnav::msg\n")
  string(APPEND cpp "\nnamespace ddsnav::msg {\nnamespace {\n${schema_defs}}  // namespace\n\n")
  foreach(type ${types})
    string(APPEND cpp "template <>\nconst TypeSupport& type_support<::${type}>() {\n"
                      "  static const TypeSupport ts = makeTypeSupport<::${type}>(\"${type}\", &${symbol_${type}});\n"
                      "  return ts;\n}\n")
  endforeach()
  string(APPEND cpp "\nnamespace {\n// Runs when the library is loaded (linked, or from DDSNAV_MESSAGE_LIBRARIES).\n"
                    "const bool registered = registerMessageLibrary(\"${target}\", {\n${list_entries}});\n"
                    "}  // namespace\n}  // namespace ddsnav::msg\n")
  file(WRITE ${gen}/messages.hpp.in "${hpp}")
  configure_file(${gen}/messages.hpp.in ${cxx_out}/messages.hpp COPYONLY)
  file(WRITE ${gen}/register.cpp.in "${cpp}")
  configure_file(${gen}/register.cpp.in ${gen}/register.cpp COPYONLY)

  add_library(${target} SHARED ${cxx_sources} ${c_sources} ${gen}/register.cpp)
  # Both generators name their headers after the IDL file (perception.h): the C++ ones must not be seen
  # from the idlc C sources and the other way round.
  set(cxx_only "")
  foreach(dir ${cxx_dirs})
    list(APPEND cxx_only "$<$<COMPILE_LANGUAGE:CXX>:${dir}>")
  endforeach()
  set(c_only "")
  foreach(dir ${c_out} ${c_dirs})
    list(APPEND c_only "$<$<COMPILE_LANGUAGE:C>:${dir}>")
  endforeach()
  target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${gen}/include> ${cxx_only}
    PRIVATE $<$<COMPILE_LANGUAGE:CXX>:${cxx_out}> ${c_only})  # the generated .cxx include "<file>.h"
  find_package(CycloneDDS REQUIRED)
  target_link_libraries(${target} PUBLIC ${link} PRIVATE CycloneDDS::ddsc)
  set_source_files_properties(${cxx_sources} ${c_sources} PROPERTIES COMPILE_OPTIONS "-w")
  set_target_properties(${target} PROPERTIES
    DDSNAV_IDL_DIRS "${idl_dirs}" DDSNAV_C_INCLUDE_DIRS "${c_out};${c_dirs}"
    DDSNAV_CXX_INCLUDE_DIRS "${cxx_out};${cxx_dirs}" DDSNAV_MESSAGE_TYPES "${types}")
endfunction()
