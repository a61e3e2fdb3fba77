"""ROS I/O without ROS: bags read as recordings (`bag_reader`, `bag_import`) and runs written as MCAP
bags (`export`)."""
