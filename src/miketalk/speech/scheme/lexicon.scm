;;; miketalk: Festival's pronunciation of words (voice_kal_diphone's lexicon, radio phones).
;;;
;;; Run as `festival -b lexicon.scm`. Everything comes in through environment
;;; variables; the words are read as string data with readfp and only ever handed
;;; to lex.lookup, never evaluated.
;;;   MIKETALK_WORDS   a file holding one Scheme list of strings, the words
;;;   MIKETALK_OUT     the file to write: one line per word, the word, a tab, and
;;;                    its phones separated by spaces (lexicon entry, or
;;;                    letter-to-sound rules for a word the lexicon lacks)

(define (miketalk-env name)
  (let ((v (getenv name)))
    (if v (string-append "" v) (begin (format stderr "miketalk: %s not set\n" name) (exit 3)))))

(define (miketalk-read-words path)
  (let ((fd (fopen path "r")) (words nil))
    (set! words (readfp fd))
    (fclose fd)
    words))

(define (miketalk-phones entry)
  "The phones of a lex.lookup entry (WORD POS SYLLABLES), syllables flattened."
  (apply append (mapcar car (car (cdr (cdr entry))))))

(define (miketalk-write-word fd word)
  (format fd "%s\t" word)
  (mapcar (lambda (phone) (format fd " %s" phone)) (miketalk-phones (lex.lookup word nil)))
  (format fd "\n"))

(define (miketalk-pronounce)
  (let ((words (miketalk-read-words (miketalk-env "MIKETALK_WORDS")))
        (fd (fopen (miketalk-env "MIKETALK_OUT") "w")))
    (mapcar (lambda (word) (miketalk-write-word fd word)) words)
    (fclose fd)))

(voice_kal_diphone)
(miketalk-pronounce)
