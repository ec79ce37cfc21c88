# dca_property_below(DIR PROPERTY OUT): the directory property PROPERTY (a list: TESTS, BUILDSYSTEM_TARGETS) of the
# folder DIR and of every folder below it, so far.
function(dca_property_below dir property out)
  get_property(items DIRECTORY ${dir} PROPERTY ${property})
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub IN LISTS subdirs)
    dca_property_below(${sub} ${property} below)
    list(APPEND items ${below})
  endforeach()
  set(${out} ${items} PARENT_SCOPE)
endfunction()
