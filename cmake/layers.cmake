# camlab_check_links(): the link arrows of docs/architecture.md, checked when CMake
# configures. target_link_libraries draws the arrows; this fails the configuration when
# one points the wrong way, through any chain of targets.

# All targets `target` links, directly or through others (camlab targets only).
function(camlab_linked_targets target out)
  set(seen "")
  set(todo ${target})
  while(todo)
    list(POP_FRONT todo current)
    foreach(property LINK_LIBRARIES INTERFACE_LINK_LIBRARIES)
      get_target_property(linked ${current} ${property})
      if(NOT linked)
        continue()
      endif()
      foreach(dep IN LISTS linked)
        if(TARGET ${dep} AND dep MATCHES "^camlab" AND NOT dep IN_LIST seen)
          list(APPEND seen ${dep})
          list(APPEND todo ${dep})
        endif()
      endforeach()
    endforeach()
  endwhile()
  set(${out} ${seen} PARENT_SCOPE)
endfunction()

# Fails when `target` reaches any of the targets after FORBIDS.
function(camlab_forbid_links target)
  cmake_parse_arguments(ARG "" "WHY" "FORBIDS" ${ARGN})
  camlab_linked_targets(${target} linked)
  foreach(forbidden IN LISTS ARG_FORBIDS)
    if(forbidden IN_LIST linked)
      message(FATAL_ERROR "${target} links ${forbidden}: ${ARG_WHY} (docs/architecture.md)")
    endif()
  endforeach()
endfunction()

function(camlab_check_links)
  set(above_src camlab_calib camlab_mock_spec camlab_mock_render camlab_mock_v4l2
                camlab_mock_broker camlab_mock_device camlabd_lib)
  foreach(room camlab_base camlab_optics camlab_image camlab_analysis camlab_device camlab_capture)
    camlab_forbid_links(${room} FORBIDS ${above_src} WHY "src/ depends on nothing above it")
  endforeach()
  # src/optics: the standard library only.
  get_target_property(optics_links camlab_optics LINK_LIBRARIES)
  if(optics_links)
    message(FATAL_ERROR "camlab_optics links ${optics_links}: it may link nothing (docs/architecture.md)")
  endif()
  camlab_forbid_links(camlab_base FORBIDS camlab_optics camlab_image camlab_analysis camlab_device
                      camlab_capture WHY "base/ is the ground floor")
  camlab_forbid_links(camlab_analysis FORBIDS camlab_device camlab_capture
                      WHY "measurements read files, not cameras")
  camlab_forbid_links(camlab_mock_render FORBIDS camlab_device camlab_capture camlab_mock_v4l2
                      WHY "the renderer knows nothing of V4L2")
  camlab_forbid_links(camlab_calib FORBIDS camlab_mock_device camlab_mock_render camlabd_lib
                      WHY "calib/ depends on src/ only")
  camlab_forbid_links(camlab_mock_device FORBIDS camlab_calib camlabd_lib
                      WHY "mock_device/ depends on src/ only")
  camlab_forbid_links(camlab_vcam_preload FORBIDS camlab camlab_base camlab_mock_v4l2
                      camlab_mock_render WHY "the preload library loads nothing heavy into its host")
endfunction()
