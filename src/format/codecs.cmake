# filled by the codecs work
