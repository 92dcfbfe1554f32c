# ctest core_is_allocation_free: the portable core uses no heap and no Arduino headers.
file(GLOB files ${DIR}/*.h ${DIR}/*.cpp)
set(bad "")
foreach(f ${files})
  file(STRINGS ${f} lines)
  foreach(line IN LISTS lines)
    if(line MATCHES "^[ ]*//")
      continue()
    endif()
    if(line MATCHES "#include[ ]*<(vector|string|map|memory|list|deque|functional|iostream|sstream|Arduino\\.h|Wire\\.h)>"
       OR line MATCHES "#include[ ]*\"(Arduino|Wire)\\.h\""
       OR line MATCHES "(^|[^a-z_])(malloc|calloc|realloc|free)[ ]*\\("
       OR line MATCHES "(^|[^a-z_])new[ ]+[A-Za-z_]"
       OR line MATCHES "std::(vector|string|function|unique_ptr|shared_ptr)")
      list(APPEND bad "${f}: ${line}")
    endif()
  endforeach()
endforeach()
list(LENGTH files n)
if(n LESS 10)
  message(FATAL_ERROR "expected the core sources in ${DIR}, found ${n} files")
endif()
if(bad)
  string(REPLACE ";" "\n" bad "${bad}")
  message(FATAL_ERROR "allocation or Arduino dependency in the core:\n${bad}")
endif()
message(STATUS "${n} core files checked")
